#include "server/auth/authorize.h"

#include <iterator>
#include <optional>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace mvbrdf::auth {
namespace {

constexpr absl::string_view kBearer = "Bearer ";

absl::string_view ServiceOf(Role needed) { return needed == Role::kWorker ? "mvbrdf.v1.Workers" : "mvbrdf.v1.Mvbrdf"; }

}  // namespace

std::string ClientLabel(const grpc::ServerContextBase& context) {
  const auto& metadata = context.client_metadata();
  auto it = metadata.find("x-mvbrdf-client");
  if (it == metadata.end() || it->second.empty()) return "anonymous";
  return std::string(it->second.data(), it->second.size());
}

absl::StatusOr<Principal> Authorize(const grpc::ServerContextBase& context, const TokenTable* tokens, Role needed) {
  if (tokens == nullptr) return Principal{ClientLabel(context), needed, false};
  const auto& metadata = context.client_metadata();
  const auto [first, last] = metadata.equal_range("authorization");
  if (first == last) {
    return absl::UnauthenticatedError(
        absl::StrCat("this server requires a token: send the metadata 'authorization: Bearer <token>' (mvbrdf: "
                     "--token-file FILE or the environment variable MVBRDF_TOKEN)"));
  }
  if (std::next(first) != last) return absl::UnauthenticatedError("authorization: sent more than once");
  const absl::string_view value(first->second.data(), first->second.size());
  // The scheme is case-insensitive (RFC 6750); the token is not.
  if (value.size() <= kBearer.size() || !absl::EqualsIgnoreCase(value.substr(0, kBearer.size()), kBearer)) {
    return absl::UnauthenticatedError("authorization: expected 'Bearer <token>'");
  }
  std::optional<Principal> principal = tokens->Lookup(value.substr(kBearer.size()));
  if (!principal.has_value()) {
    return absl::UnauthenticatedError("authorization: the token is not known to this server");
  }
  const bool allowed = principal->role == Role::kAdmin || principal->role == needed;
  if (!allowed) {
    return absl::PermissionDeniedError(
        absl::StrCat(RoleName(principal->role), " token \"", principal->name, "\" may not call ", ServiceOf(needed),
                     " (it needs a ", RoleName(needed), needed == Role::kAdmin ? "" : " or admin", " token)"));
  }
  return *std::move(principal);
}

bool MayAccessJob(const Principal& principal, absl::string_view owner) {
  return !principal.authenticated || principal.role == Role::kAdmin || principal.name == owner;
}

}  // namespace mvbrdf::auth
