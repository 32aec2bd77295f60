// SHA-256 digests (OpenSSL EVP) and random identifiers.
#ifndef MVBRDF_SERVER_STORE_DIGEST_H_
#define MVBRDF_SERVER_STORE_DIGEST_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::store {

// Incremental SHA-256: Update() any number of times, then FinishHex() once.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;

  void Update(absl::string_view bytes);
  // 64 lowercase hex digits.
  std::string FinishHex();

 private:
  struct Context;
  std::unique_ptr<Context> context_;
};

// SHA-256 of `bytes` as 64 lowercase hex digits.
std::string Sha256Hex(absl::string_view bytes);

// True for exactly 64 lowercase hex digits: the only form of digest that may
// become part of a path.
bool IsSha256Hex(absl::string_view text);

// 128 random bits from the OS CSPRNG as 32 lowercase hex digits (job and
// task ids: unguessable, unique without coordination).
absl::StatusOr<std::string> RandomId128();

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_DIGEST_H_
