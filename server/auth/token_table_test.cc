#include "server/auth/token_table.h"

#include <gtest/gtest.h>

namespace mvbrdf::auth {
namespace {

constexpr char kAliceToken[] = "alice-secret-0123456789";

TEST(TokenTableTest, ParsesRolesNamesAndDigestsAndLooksUpByToken) {
  const std::string text =
      std::string("# role name token\n\nclient alice ") + kAliceToken + "\n  admin\tops   ops-secret-0123456789  \n";
  absl::StatusOr<TokenTable> table = TokenTable::Parse(text, "tokens.txt");
  ASSERT_TRUE(table.ok()) << table.status();
  EXPECT_EQ(table->size(), 2u);
  std::optional<Principal> alice = table->Lookup(kAliceToken);
  ASSERT_TRUE(alice.has_value());
  EXPECT_EQ(alice->name, "alice");
  EXPECT_EQ(alice->role, Role::kClient);
  EXPECT_TRUE(alice->authenticated);
  std::optional<Principal> ops = table->Lookup("ops-secret-0123456789");
  ASSERT_TRUE(ops.has_value());
  EXPECT_EQ(ops->role, Role::kAdmin);
  EXPECT_FALSE(table->Lookup("alice-secret-012345678").has_value());  // one character short
  EXPECT_FALSE(table->Lookup("").has_value());
}

// A digest entry is matched by its token, never by the digest itself.
TEST(TokenTableTest, DigestEntryIsNotMatchedByTheDigestText) {
  const std::string digest = "9f9f5111f7b27a781f1f1ddde5ebc2dd2b796bfc7365c9c28b548e564176929f";
  absl::StatusOr<TokenTable> table = TokenTable::Parse("worker gpu-1 sha256:" + digest + "\n", "t");
  ASSERT_TRUE(table.ok()) << table.status();
  EXPECT_FALSE(table->Lookup(digest).has_value());
  EXPECT_FALSE(table->Lookup("sha256:" + digest).has_value());
}

TEST(TokenTableTest, ErrorsNameTheLineAndFieldButNeverTheToken) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const std::string secret = "do-not-print-this-secret";
  const std::vector<Case> cases = {
      {"client alice\n", "t:1: expected 'role name token' (3 fields), got 2"},
      {"\nroot alice " + secret + "\n", "t:2: role: expected client, worker or admin, got \"root\""},
      {"client al/ice " + secret, "t:1: name: expected 1..64 characters"},
      {"client alice short", "t:1: token: must have 16..4096 characters, got 5"},
      {"client alice sha256:abc", "t:1: token: \"sha256:\" must be followed by 64 lowercase hex digits"},
      {"client alice " + secret + "\nworker alice x" + secret, "t:2: name: \"alice\" appears twice"},
      {"client alice " + secret + "\nworker bob " + secret, "t:2: token: the same token as \"alice\""},
      {"# nothing\n\n", "t: no tokens"},
  };
  for (const Case& c : cases) {
    absl::StatusOr<TokenTable> table = TokenTable::Parse(c.text, "t");
    ASSERT_FALSE(table.ok()) << c.text;
    EXPECT_EQ(table.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(table.status().message().find(c.expected), std::string::npos) << table.status();
    EXPECT_EQ(table.status().message().find(secret), std::string::npos) << table.status();
  }
}

TEST(TokenTableTest, DigestEntryMatchesItsToken) {
  // sha256("0123456789abcdef") computed independently (sha256sum).
  absl::StatusOr<TokenTable> table =
      TokenTable::Parse("worker w sha256:9f9f5111f7b27a781f1f1ddde5ebc2dd2b796bfc7365c9c28b548e564176929f\n", "t");
  ASSERT_TRUE(table.ok()) << table.status();
  std::optional<Principal> w = table->Lookup("0123456789abcdef");
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(w->name, "w");
  EXPECT_EQ(w->role, Role::kWorker);
}

TEST(TokenTableTest, MissingFileIsNotFound) {
  EXPECT_EQ(TokenTable::ReadFile("/nonexistent/tokens.txt").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace mvbrdf::auth
