// Streaming handlers that refuse a call before doing anything (e.g. when
// Authorize fails): a reactor that finishes at once with the status.
#ifndef MVBRDF_SERVER_AUTH_FAILED_REACTOR_H_
#define MVBRDF_SERVER_AUTH_FAILED_REACTOR_H_

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"

namespace mvbrdf::auth {

// absl and gRPC share the canonical status codes and their numbers.
inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

// Server-streaming: deletes itself when gRPC is done with it.
template <class Response>
class FailedWriteReactor final : public grpc::ServerWriteReactor<Response> {
 public:
  explicit FailedWriteReactor(const absl::Status& status) { this->Finish(ToGrpcStatus(status)); }
  void OnDone() override { delete this; }
};

// Client-streaming.
template <class Request>
class FailedReadReactor final : public grpc::ServerReadReactor<Request> {
 public:
  explicit FailedReadReactor(const absl::Status& status) { this->Finish(ToGrpcStatus(status)); }
  void OnDone() override { delete this; }
};

}  // namespace mvbrdf::auth

#endif  // MVBRDF_SERVER_AUTH_FAILED_REACTOR_H_
