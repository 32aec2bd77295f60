#include "server/store/digest.h"

#include <openssl/evp.h>
#include <openssl/rand.h>

#include <cstdio>
#include <cstdlib>

namespace mvbrdf::store {
namespace {

std::string ToHex(const unsigned char* bytes, size_t size) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex(2 * size, '0');
  for (size_t i = 0; i < size; ++i) {
    hex[2 * i] = kDigits[bytes[i] >> 4];
    hex[2 * i + 1] = kDigits[bytes[i] & 0xf];
  }
  return hex;
}

// A programmer invariant or libcrypto failing on memory: nothing a caller
// can handle (abseil's CHECK is not in this abseil release).
void Require(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "mvbrdf::store::Sha256: %s\n", what);
    std::abort();
  }
}

}  // namespace

struct Sha256::Context {
  EVP_MD_CTX* ctx = nullptr;
  bool finished = false;
};

Sha256::Sha256() : context_(std::make_unique<Context>()) {
  context_->ctx = EVP_MD_CTX_new();
  Require(context_->ctx != nullptr, "EVP_MD_CTX_new failed");
  Require(EVP_DigestInit_ex(context_->ctx, EVP_sha256(), nullptr) == 1, "EVP_DigestInit_ex(sha256) failed");
}

Sha256::~Sha256() { EVP_MD_CTX_free(context_->ctx); }

void Sha256::Update(absl::string_view bytes) {
  Require(!context_->finished, "Update after FinishHex");
  Require(EVP_DigestUpdate(context_->ctx, bytes.data(), bytes.size()) == 1, "EVP_DigestUpdate failed");
}

std::string Sha256::FinishHex() {
  Require(!context_->finished, "FinishHex called twice");
  context_->finished = true;
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  Require(EVP_DigestFinal_ex(context_->ctx, digest, &size) == 1, "EVP_DigestFinal_ex failed");
  return ToHex(digest, size);
}

std::string Sha256Hex(absl::string_view bytes) {
  Sha256 sha;
  sha.Update(bytes);
  return sha.FinishHex();
}

bool IsSha256Hex(absl::string_view text) {
  if (text.size() != 64) return false;
  for (char c : text) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

absl::StatusOr<std::string> RandomId128() {
  unsigned char bytes[16];
  if (RAND_bytes(bytes, sizeof(bytes)) != 1) {
    return absl::UnavailableError("RAND_bytes: the OS random source is not available");
  }
  return ToHex(bytes, sizeof(bytes));
}

}  // namespace mvbrdf::store
