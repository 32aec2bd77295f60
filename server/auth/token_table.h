// The server's bearer tokens (issue #7, docs/service.md "Security"): who may
// call, under which name, in which role. Read from a tokens file, one entry a
// line:
//
//   # role   name      token
//   client   alice     6f1d0c2e9a7b4f03b5e8c1d2a3f4e5d6
//   worker   gpu-box-1 sha256:9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08
//   admin    ops       0b7e...
//
// role: client (the Mvbrdf service, its own jobs), worker (the Workers
// service) or admin (both, and every client's jobs). name: the principal,
// 1..64 of [A-Za-z0-9._@-], unique. token: at least 16 printable characters
// without spaces, or "sha256:" and the 64 lowercase hex digits of the token's
// SHA-256 (so the file need not hold the secret). Blank lines and lines
// starting with '#' are ignored.
//
// Only the SHA-256 of each token is kept in memory. Lookup hashes the
// presented token and compares it with every entry in constant time (no
// early exit), so neither the timing nor an error message tells anything
// about the tokens. Errors never contain a token.
//
// Threading: immutable after construction; any thread may call Lookup.
#ifndef MVBRDF_SERVER_AUTH_TOKEN_TABLE_H_
#define MVBRDF_SERVER_AUTH_TOKEN_TABLE_H_

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::auth {

enum class Role { kClient, kWorker, kAdmin };

// "client", "worker", "admin".
absl::string_view RoleName(Role role);

// Who made a call.
struct Principal {
  std::string name;
  Role role = Role::kClient;
  // False when the server has no tokens (authentication off): `name` is then
  // the caller's unauthenticated "x-mvbrdf-client" label.
  bool authenticated = false;
};

class TokenTable {
 public:
  // Parses the file's text; `origin` (the file name) prefixes errors, with
  // the line: "tokens.txt:3: role: expected client, worker or admin, got
  // \"x\"". INVALID_ARGUMENT for a malformed line, a duplicate name or token,
  // or no entry at all.
  static absl::StatusOr<TokenTable> Parse(absl::string_view text, absl::string_view origin);
  // Reads and parses `path`; NOT_FOUND when it cannot be read.
  static absl::StatusOr<TokenTable> ReadFile(const std::filesystem::path& path);

  // The principal holding `token`, if any.
  std::optional<Principal> Lookup(absl::string_view token) const;
  size_t size() const { return entries_.size(); }

 private:
  using Digest = std::array<uint8_t, 32>;
  struct Entry {
    Digest digest;  // SHA-256 of the token
    std::string name;
    Role role;
  };
  static Digest Sha256(absl::string_view bytes);
  std::vector<Entry> entries_;
};

}  // namespace mvbrdf::auth

#endif  // MVBRDF_SERVER_AUTH_TOKEN_TABLE_H_
