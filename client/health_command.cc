// `mvbrdf health --server HOST:PORT [--service NAME] [--tls-ca FILE ...]`:
// one grpc.health.v1.Health/Check call; exit 0 when the answer is SERVING.
//
// For probes that must speak TLS: Kubernetes' native gRPC probe (and
// compose's healthcheck, which only runs a command) cannot, so the container
// image's exec probe runs this (deploy/k8s, docs/deploy.md). The health
// service needs no token, so none is sent unless --token-file or
// MVBRDF_TOKEN gives one (harmless: the health service ignores it).
//
// The messages are encoded by hand (grpc/health/v1/health.proto is not one of
// our protos and libgrpc++'s health stubs are not installed):
//   HealthCheckRequest  { string service = 1; }
//   HealthCheckResponse { ServingStatus status = 1; }  SERVING = 1
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <future>
#include <string>
#include <vector>

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"

namespace mvbrdf::client {
namespace {

constexpr int kServing = 1;

std::string EncodeRequest(const std::string& service) {
  if (service.empty()) return {};
  std::string bytes(1, '\x0a');  // field 1, length-delimited
  for (uint64_t n = service.size();; n >>= 7) {
    if (n < 0x80) {
      bytes.push_back(static_cast<char>(n));
      break;
    }
    bytes.push_back(static_cast<char>((n & 0x7f) | 0x80));
  }
  return bytes + service;
}

// The status field of a HealthCheckResponse; 0 (UNKNOWN) when absent or
// unparsable. The response is one varint field.
int DecodeStatus(const std::string& bytes) {
  if (bytes.size() < 2 || bytes[0] != '\x08') return 0;
  int status = 0;
  for (size_t i = 1, shift = 0; i < bytes.size() && shift < 28; ++i, shift += 7) {
    status |= (bytes[i] & 0x7f) << shift;
    if ((bytes[i] & 0x80) == 0) break;
  }
  return status;
}

const char* StatusName(int status) {
  switch (status) {
    case 0:
      return "UNKNOWN";
    case 1:
      return "SERVING";
    case 2:
      return "NOT_SERVING";
    case 3:
      return "SERVICE_UNKNOWN";
    default:
      return "unrecognised";
  }
}

}  // namespace

int RunHealth(const std::vector<std::string>& args) {
  std::string address, service;
  int timeout_seconds = 5;
  FlagParser flags("health",
                   "Asks a server's standard health service (grpc.health.v1.Health/Check) whether it is serving; "
                   "for container probes over TLS. Prints the status. Exit 0: SERVING; 4: unreachable or not "
                   "serving; 3: the server does not know --service.");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--service NAME", &service, "the service to ask about (default: the whole server)");
  flags.AddInt("--timeout SECONDS", &timeout_seconds, "seconds to wait for the answer");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf health: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf health: --server: required\n");
    return kExitUsage;
  }
  if (timeout_seconds <= 0) {
    std::fprintf(stderr, "mvbrdf health: --timeout: must be > 0, got %d\n", timeout_seconds);
    return kExitUsage;
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf health: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  grpc::GenericStub generic(*channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(timeout_seconds));
  const std::string request_bytes = EncodeRequest(service);
  grpc::Slice slice(request_bytes);
  grpc::ByteBuffer request(&slice, 1), response;
  std::promise<grpc::Status> done;
  generic.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                    [&done](grpc::Status s) { done.set_value(s); });
  const grpc::Status status = done.get_future().get();
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf health: error: %s: %s\n", address.c_str(), status.error_message().c_str());
    return ExitCodeForRpc(status.error_code());
  }
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (response.Dump(&slices).ok()) {
    for (const grpc::Slice& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  }
  const int serving = DecodeStatus(bytes);
  std::printf("%s\n", StatusName(serving));
  return serving == kServing ? kExitOk : kExitEnvironment;
}

}  // namespace mvbrdf::client
