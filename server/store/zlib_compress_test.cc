#include "server/store/zlib_compress.h"

#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>

#include "gtest/gtest.h"

namespace mvbrdf::store {
namespace {

// Bytes that deflate like gathered Samples do, partly: little-endian floats
// of a smooth signal with noise in their low bits.
std::string SampleLikeBytes(size_t size, uint32_t seed) {
  std::mt19937 random(seed);
  std::string bytes(size, '\0');
  for (size_t i = 0; i + 4 <= size; i += 4) {
    const float v = 0.5f + 0.25f * static_cast<float>(std::sin(static_cast<double>(i) * 1e-3)) +
                    1e-4f * static_cast<float>(random() % 1000);
    std::memcpy(&bytes[i], &v, 4);
  }
  return bytes;
}

std::string Uncompressed(const std::string& stored, size_t raw_size) {
  std::string out(raw_size + 1, '\0');
  uLongf size = static_cast<uLongf>(out.size());
  const int code = uncompress(reinterpret_cast<Bytef*>(out.data()), &size,
                              reinterpret_cast<const Bytef*>(stored.data()), static_cast<uLong>(stored.size()));
  EXPECT_EQ(code, Z_OK);
  out.resize(size);
  return out;
}

std::string Compress2(const std::string& bytes, int level) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::string out(size, '\0');
  EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(out.data()), &size, reinterpret_cast<const Bytef*>(bytes.data()),
                      static_cast<uLong>(bytes.size()), level),
            Z_OK);
  out.resize(size);
  return out;
}

TEST(ZlibCompressTest, UncompressReadsEverySplitAtEveryLevel) {
  const std::string bytes = SampleLikeBytes(100003, 1);
  for (int level : {1, 6, 9}) {
    const std::string one = Compress2(bytes, level);
    for (size_t chunk : {size_t{1000}, size_t{4096}, size_t{33333}, size_t{50002}}) {
      for (int threads : {1, 3}) {
        SCOPED_TRACE(testing::Message() << "level " << level << ", chunks of " << chunk << ", " << threads
                                        << " threads");
        absl::StatusOr<std::string> stored = ZlibCompress(bytes, {level, chunk, threads});
        ASSERT_TRUE(stored.ok()) << stored.status();
        EXPECT_EQ(Uncompressed(*stored, bytes.size()), bytes);
        // zlib's own header for the level (FLEVEL), and a stream that is not
        // compress2's (the chunks were deflated apart).
        EXPECT_EQ(stored->substr(0, 2), one.substr(0, 2));
        EXPECT_NE(*stored, one);
        // The same bytes whatever the threads.
        EXPECT_EQ(*stored, *ZlibCompress(bytes, {level, chunk, 1}));
        // Chunks cost a little ratio, not much.
        EXPECT_LT(stored->size(), bytes.size());
      }
    }
  }
}

TEST(ZlibCompressTest, OneChunkIsCompress2sOutput) {
  for (size_t size : {size_t{0}, size_t{1}, size_t{4096}}) {
    const std::string bytes = SampleLikeBytes(size, 2);
    absl::StatusOr<std::string> stored = ZlibCompress(bytes, {1, 4096, 2});
    ASSERT_TRUE(stored.ok()) << stored.status();
    EXPECT_EQ(*stored, Compress2(bytes, 1)) << size << " bytes";
  }
}

TEST(ZlibCompressTest, LastChunkShorterOrOneByte) {
  for (size_t size : {size_t{8193}, size_t{8191}, size_t{3 * 4096}}) {
    const std::string bytes = SampleLikeBytes(size, 3);
    absl::StatusOr<std::string> stored = ZlibCompress(bytes, {1, 4096, 2});
    ASSERT_TRUE(stored.ok()) << stored.status();
    EXPECT_EQ(Uncompressed(*stored, bytes.size()), bytes) << size << " bytes";
  }
}

TEST(ZlibCompressTest, OptionsOutOfRangeAreRefused) {
  for (int level : {0, 10, -1}) {
    absl::StatusOr<std::string> stored = ZlibCompress("abc", {level, 4096, 1});
    ASSERT_FALSE(stored.ok());
    EXPECT_NE(stored.status().message().find("level"), std::string::npos) << stored.status();
  }
  absl::StatusOr<std::string> stored = ZlibCompress("abc", {1, 0, 1});
  ASSERT_FALSE(stored.ok());
  EXPECT_NE(stored.status().message().find("chunk_bytes"), std::string::npos) << stored.status();
}

}  // namespace
}  // namespace mvbrdf::store
