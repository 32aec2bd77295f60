#include "server/store/digest.h"

#include <gtest/gtest.h>

#include <string>

namespace mvbrdf::store {
namespace {

TEST(DigestTest, KnownSha256) {
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_TRUE(IsSha256Hex(Sha256Hex("")));
  EXPECT_FALSE(IsSha256Hex("../etc/passwd"));
  EXPECT_FALSE(IsSha256Hex(std::string(64, 'A')));
  auto a = RandomId128();
  auto b = RandomId128();
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->size(), 32u);
  EXPECT_NE(*a, *b);
}

TEST(DigestTest, IncrementalMatchesOneShot) {
  Sha256 sha;
  sha.Update("a");
  sha.Update("");
  sha.Update("bc");
  EXPECT_EQ(sha.FinishHex(), Sha256Hex("abc"));
}

}  // namespace
}  // namespace mvbrdf::store
