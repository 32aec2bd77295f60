// Authorising one gRPC call (issue #7): every handler of the Mvbrdf and
// Workers services starts with Authorize(context, tokens, role).
//
// With a TokenTable the call must carry the metadata
// "authorization: Bearer <token>" of a known token whose role may call the
// service: client methods need a client or admin token, worker methods a
// worker or admin token. Otherwise UNAUTHENTICATED (no, malformed or unknown
// token; the message says what is expected and never repeats the token) or
// PERMISSION_DENIED (a known token of the wrong role).
//
// Without a table (tokens == nullptr) authentication is off (local use,
// `mvbrdf run`): every call is let in, as the "x-mvbrdf-client" label or
// "anonymous", with Principal.authenticated false.
//
// Health checking (grpc.health.v1) and reflection are not our handlers and
// stay open: probes need no token.
#ifndef MVBRDF_SERVER_AUTH_AUTHORIZE_H_
#define MVBRDF_SERVER_AUTH_AUTHORIZE_H_

#include <grpcpp/grpcpp.h>

#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/auth/token_table.h"

namespace mvbrdf::auth {

// `needed`: kClient for mvbrdf.v1.Mvbrdf, kWorker for mvbrdf.v1.Workers
// (kAdmin: admin tokens only).
absl::StatusOr<Principal> Authorize(const grpc::ServerContextBase& context, const TokenTable* tokens, Role needed);

// Whether `principal` may see and act on a job submitted by `owner`: its own
// jobs, every job for an admin, and every job when authentication is off.
bool MayAccessJob(const Principal& principal, absl::string_view owner);

// The caller's unauthenticated "x-mvbrdf-client" label, or "anonymous".
std::string ClientLabel(const grpc::ServerContextBase& context);

}  // namespace mvbrdf::auth

#endif  // MVBRDF_SERVER_AUTH_AUTHORIZE_H_
