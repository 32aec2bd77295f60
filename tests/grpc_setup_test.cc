// The service's build and transport set-up (issue #5): the generated stubs
// link, a server with the mvbrdf services, standard health checking and
// reflection starts on a loopback port chosen by the OS, and a real channel
// reaches it. The services' behaviour is tested where they are implemented.
#include <future>
#include <memory>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <gtest/gtest.h>

#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf {
namespace {

TEST(GrpcSetupTest, ServerWithHealthAndReflectionAnswersOnLoopback) {
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  v1::Mvbrdf::Service mvbrdf_service;
  v1::Workers::Service workers_service;
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&mvbrdf_service);
  builder.RegisterService(&workers_service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  ASSERT_NE(server, nullptr);
  ASSERT_GT(port, 0);

  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  // grpc.health.v1.Health/Check with an empty HealthCheckRequest; the
  // response HealthCheckResponse{status: SERVING} encodes as 08 01.
  grpc::GenericStub generic(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  grpc::ByteBuffer request, response;
  grpc::Slice empty("");
  request = grpc::ByteBuffer(&empty, 1);
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&done](grpc::Status status) { done.set_value(status); });
  const grpc::Status health = done.get_future().get();
  ASSERT_TRUE(health.ok()) << health.error_message();
  std::vector<grpc::Slice> slices;
  ASSERT_TRUE(response.Dump(&slices).ok());
  std::string bytes;
  for (const grpc::Slice& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  EXPECT_EQ(bytes, std::string("\x08\x01", 2));

  // The generated client reaches the registered service over the channel.
  auto stub = v1::Mvbrdf::NewStub(channel);
  grpc::ClientContext list_context;
  list_context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::ListJobsResponse jobs;
  const grpc::Status list = stub->ListJobs(&list_context, v1::ListJobsRequest(), &jobs);
  EXPECT_NE(list.error_code(), grpc::StatusCode::UNAVAILABLE) << list.error_message();
  server->Shutdown();
}

}  // namespace
}  // namespace mvbrdf
