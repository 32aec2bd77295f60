#include "server/process/server.h"

#include <fstream>
#include <future>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "mvbrdf/v1/service.grpc.pb.h"
#include "server/store/digest.h"

namespace mvbrdf::server {
namespace {

std::filesystem::path TempDataDir() {
  const auto dir = std::filesystem::temp_directory_path() / ("mvbrdf_server_test_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

TEST(ServerTest, BadOptionsNameTheFlag) {
  ServerOptions options;
  EXPECT_NE(Server::Start(options).status().message().find("--data"), std::string::npos);
  options.data_dir = TempDataDir();
  options.listen_address = "nonsense";
  EXPECT_NE(Server::Start(options).status().message().find("--listen"), std::string::npos);
}

// Both services, health checking and the store answer over a real channel;
// the state survives a restart on the same data directory.
TEST(ServerTest, ServesBothServicesAndHealthAndKeepsStateAcrossRestarts) {
  ServerOptions options;
  options.data_dir = TempDataDir();
  auto server = Server::Start(options);
  ASSERT_TRUE(server.ok()) << server.status();
  EXPECT_NE((*server)->address().find("127.0.0.1:"), std::string::npos);
  auto channel = grpc::CreateChannel((*server)->address(), grpc::InsecureChannelCredentials());

  // grpc.health.v1.Health/Check → HealthCheckResponse{status: SERVING} = 08 01.
  grpc::GenericStub generic(channel);
  grpc::ClientContext health_context;
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&health_context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&done](grpc::Status s) { done.set_value(s); });
  ASSERT_TRUE(done.get_future().get().ok());

  auto workers = v1::Workers::NewStub(channel);
  grpc::ClientContext register_context;
  v1::RegisterWorkerRequest worker;
  worker.set_name("test-worker");
  worker.set_gl_renderer("llvmpipe");
  v1::RegisterWorkerResponse registered;
  ASSERT_TRUE(workers->RegisterWorker(&register_context, worker, &registered).ok());
  EXPECT_FALSE(registered.worker_id().empty());

  auto clients = v1::Mvbrdf::NewStub(channel);
  grpc::ClientContext list_context;
  v1::ListJobsResponse jobs;
  const grpc::Status listed = clients->ListJobs(&list_context, v1::ListJobsRequest(), &jobs);
  ASSERT_TRUE(listed.ok()) << listed.error_message();
  EXPECT_EQ(jobs.jobs_size(), 0);
  // A job for an unknown bundle is refused with a reason; the server keeps serving.
  grpc::ClientContext submit_context;
  v1::SubmitJobRequest submit;
  submit.set_bundle_sha256(std::string(64, 'a'));
  v1::SubmitJobResponse submitted;
  const grpc::Status refused = clients->SubmitJob(&submit_context, submit, &submitted);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << refused.error_message();
  grpc::ClientContext again;
  EXPECT_TRUE(clients->ListJobs(&again, v1::ListJobsRequest(), &jobs).ok());
  server->reset();

  // Restart on the same directory: the database is there and opens.
  auto restarted = Server::Start(options);
  ASSERT_TRUE(restarted.ok()) << restarted.status();
  EXPECT_TRUE(std::filesystem::exists(options.data_dir / "state.db"));
  std::filesystem::remove_all(options.data_dir);
}

// Workers fetch bundles from where the clients service put them, and an
// embedding process reaches the stores through the accessors.
TEST(ServerTest, WorkersFetchUploadedBundlesAndTheStoresAreReachableInProcess) {
  ServerOptions options;
  options.data_dir = TempDataDir();
  options.sample_cache.max_stored_bytes = 1 << 20;
  auto server = Server::Start(options);
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string bundle = "not really a tar, but bytes all the same";
  const std::string sha256 = store::Sha256Hex(bundle);
  std::filesystem::create_directories(options.data_dir / "bundles");
  {
    std::ofstream out(options.data_dir / "bundles" / (sha256 + ".tar"), std::ios::binary);
    out << bundle;
  }
  auto channel = grpc::CreateChannel((*server)->address(), grpc::InsecureChannelCredentials());
  auto workers = v1::Workers::NewStub(channel);
  grpc::ClientContext register_context;
  v1::RegisterWorkerRequest worker;
  worker.set_name("test-worker");
  v1::RegisterWorkerResponse registered;
  ASSERT_TRUE(workers->RegisterWorker(&register_context, worker, &registered).ok());

  grpc::ClientContext fetch_context;
  v1::FetchBundleRequest fetch;
  fetch.set_worker_id(registered.worker_id());
  fetch.set_sha256(sha256);
  auto reader = workers->FetchBundle(&fetch_context, fetch);
  std::string received;
  v1::ArtifactChunk chunk;
  while (reader->Read(&chunk)) received += chunk.data();
  const grpc::Status fetched = reader->Finish();
  ASSERT_TRUE(fetched.ok()) << fetched.error_message();
  EXPECT_EQ(received, bundle);

  auto jobs = (*server)->jobs().ListJobs("anonymous");
  ASSERT_TRUE(jobs.ok()) << jobs.status();
  EXPECT_TRUE(jobs->empty());
  auto artifacts = (*server)->artifacts().ArtifactsOfJob("none");
  ASSERT_TRUE(artifacts.ok()) << artifacts.status();
  EXPECT_TRUE((*server)->workers().FindWorker(registered.worker_id()).has_value());
  auto stats = (*server)->sample_cache().Stats();
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_EQ(stats->entries, 0);
  (*server)->clients().PushEvent(v1::JobEvent());  // no watchers: a no-op
  server->reset();
  std::filesystem::remove_all(options.data_dir);
}

}  // namespace
}  // namespace mvbrdf::server
