#include "server/auth/token_table.h"

#include <openssl/crypto.h>
#include <openssl/sha.h>

#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/files.h"

namespace mvbrdf::auth {
namespace {

constexpr size_t kMinTokenChars = 16;
constexpr size_t kMaxTokenChars = 4096;
constexpr size_t kMaxNameChars = 64;
constexpr absl::string_view kDigestPrefix = "sha256:";

bool NameChar(char c) {
  return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-' || c == '@';
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

absl::string_view RoleName(Role role) {
  switch (role) {
    case Role::kClient:
      return "client";
    case Role::kWorker:
      return "worker";
    case Role::kAdmin:
      return "admin";
  }
  return "?";
}

TokenTable::Digest TokenTable::Sha256(absl::string_view bytes) {
  Digest digest;
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), digest.data());
  return digest;
}

absl::StatusOr<TokenTable> TokenTable::Parse(absl::string_view text, absl::string_view origin) {
  TokenTable table;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line.front() == '#') continue;
    const std::string where = absl::StrCat(origin, ":", line_number, ": ");
    std::vector<absl::string_view> fields = absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    if (fields.size() != 3) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, "expected 'role name token' (3 fields), got ", fields.size(), " fields"));
    }
    Entry entry;
    if (fields[0] == "client") {
      entry.role = Role::kClient;
    } else if (fields[0] == "worker") {
      entry.role = Role::kWorker;
    } else if (fields[0] == "admin") {
      entry.role = Role::kAdmin;
    } else {
      return absl::InvalidArgumentError(
          absl::StrCat(where, "role: expected client, worker or admin, got \"", fields[0].substr(0, 32), "\""));
    }
    const absl::string_view name = fields[1];
    bool name_ok = !name.empty() && name.size() <= kMaxNameChars;
    for (char c : name) name_ok = name_ok && NameChar(c);
    if (!name_ok) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, "name: expected 1..", kMaxNameChars, " characters of [A-Za-z0-9._@-]"));
    }
    entry.name = std::string(name);
    // The token itself never appears in an error.
    const absl::string_view token = fields[2];
    if (token.substr(0, kDigestPrefix.size()) == kDigestPrefix) {
      const absl::string_view hex = token.substr(kDigestPrefix.size());
      bool hex_ok = hex.size() == 2 * entry.digest.size();
      for (size_t i = 0; hex_ok && i < entry.digest.size(); ++i) {
        const int hi = HexValue(hex[2 * i]), lo = HexValue(hex[2 * i + 1]);
        hex_ok = hi >= 0 && lo >= 0;
        entry.digest[i] = static_cast<uint8_t>(hi * 16 + lo);
      }
      if (!hex_ok) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, "token: \"sha256:\" must be followed by 64 lowercase hex digits"));
      }
    } else {
      if (token.size() < kMinTokenChars || token.size() > kMaxTokenChars) {
        return absl::InvalidArgumentError(absl::StrCat(where, "token: must have ", kMinTokenChars, "..", kMaxTokenChars,
                                                       " characters, got ", token.size()));
      }
      entry.digest = Sha256(token);
    }
    for (const Entry& other : table.entries_) {
      if (other.name == entry.name) {
        return absl::InvalidArgumentError(absl::StrCat(where, "name: \"", entry.name, "\" appears twice"));
      }
      if (other.digest == entry.digest) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, "token: the same token as \"", other.name, "\" (each principal needs its own)"));
      }
    }
    table.entries_.push_back(std::move(entry));
  }
  if (table.entries_.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(origin, ": no tokens (expected lines 'role name token')"));
  }
  return table;
}

absl::StatusOr<TokenTable> TokenTable::ReadFile(const std::filesystem::path& path) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) return absl::NotFoundError(absl::StrCat(path.string(), ": cannot read the tokens file"));
  return Parse(*text, path.string());
}

std::optional<Principal> TokenTable::Lookup(absl::string_view token) const {
  const Digest digest = Sha256(token);
  const Entry* found = nullptr;
  // Every entry is compared (no early exit); digests are unique.
  for (const Entry& entry : entries_) {
    if (CRYPTO_memcmp(entry.digest.data(), digest.data(), digest.size()) == 0) found = &entry;
  }
  if (found == nullptr) return std::nullopt;
  return Principal{found->name, found->role, true};
}

}  // namespace mvbrdf::auth
