#include "server/store/zlib_compress.h"

#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"

namespace mvbrdf::store {
namespace {

absl::StatusOr<std::string> Compress2(absl::string_view bytes, int level) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::string out(size, '\0');
  const int code = compress2(reinterpret_cast<Bytef*>(out.data()), &size,
                             reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uLong>(bytes.size()), level);
  if (code != Z_OK) return absl::InternalError(absl::StrCat("zlib compress2 failed with code ", code));
  out.resize(size);
  return out;
}

// One chunk as raw deflate, ended by Z_SYNC_FLUSH (byte-aligned, not final)
// or, for the last, Z_FINISH. Empty on success, else the error.
std::string DeflateChunk(absl::string_view in, int level, bool last, std::string* out) {
  z_stream z{};
  int code = deflateInit2(&z, level, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
  if (code != Z_OK) return absl::StrCat("deflateInit2 failed with code ", code);
  // deflateBound covers the stream's end; a sync flush adds at most an empty
  // stored block (5 bytes) and a partial byte.
  out->assign(deflateBound(&z, static_cast<uLong>(in.size())) + 16, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out->data());
  z.avail_out = static_cast<uInt>(out->size());
  code = deflate(&z, last ? Z_FINISH : Z_SYNC_FLUSH);
  const bool done = last ? code == Z_STREAM_END : code == Z_OK && z.avail_in == 0 && z.avail_out > 0;
  out->resize(out->size() - z.avail_out);
  deflateEnd(&z);
  return done ? std::string() : absl::StrCat("deflate failed with code ", code);
}

}  // namespace

absl::StatusOr<std::string> ZlibCompress(absl::string_view bytes, const ZlibCompressOptions& options) {
  if (options.level < 1 || options.level > 9) {
    return absl::InvalidArgumentError(absl::StrCat("ZlibCompressOptions.level: must be in [1, 9], got ", options.level));
  }
  if (options.chunk_bytes == 0 || options.chunk_bytes > (size_t{1} << 30)) {
    return absl::InvalidArgumentError(
        absl::StrCat("ZlibCompressOptions.chunk_bytes: must be in [1, 2^30], got ", options.chunk_bytes));
  }
  const size_t chunks = std::max<size_t>(1, (bytes.size() + options.chunk_bytes - 1) / options.chunk_bytes);
  if (chunks == 1) return Compress2(bytes, options.level);
  const size_t hardware = std::max(1u, std::thread::hardware_concurrency());
  const size_t threads = std::min(chunks, options.threads > 0 ? static_cast<size_t>(options.threads) : hardware);

  std::vector<std::string> parts(chunks), errors(chunks);
  std::vector<uLong> adlers(chunks);
  std::atomic<size_t> next{0};
  const auto work = [&] {
    for (size_t k = next++; k < chunks; k = next++) {
      const absl::string_view in = bytes.substr(k * options.chunk_bytes, options.chunk_bytes);
      adlers[k] = adler32(adler32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(in.data()),
                          static_cast<uInt>(in.size()));
      errors[k] = DeflateChunk(in, options.level, k + 1 == chunks, &parts[k]);
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (size_t k = 0; k < chunks; ++k) {
    if (!errors[k].empty()) return absl::InternalError(absl::StrCat("zlib: chunk ", k, " of ", chunks, ": ", errors[k]));
  }

  // The zlib header deflate writes (RFC 1950: CM 8, a 32 KiB window, FLEVEL
  // from the level as zlib sets it, FCHECK) and the whole's Adler-32.
  const int flevel = options.level < 2 ? 0 : options.level < 6 ? 1 : options.level == 6 ? 2 : 3;
  unsigned header = (Z_DEFLATED + ((MAX_WBITS - 8) << 4)) << 8 | static_cast<unsigned>(flevel) << 6;
  header += 31 - header % 31;
  uLong adler = adlers[0];
  for (size_t k = 1; k < chunks; ++k) {
    const size_t length = std::min(options.chunk_bytes, bytes.size() - k * options.chunk_bytes);
    adler = adler32_combine(adler, adlers[k], static_cast<z_off_t>(length));
  }
  size_t total = 2 + 4;
  for (const std::string& part : parts) total += part.size();
  std::string out;
  out.reserve(total);
  out.push_back(static_cast<char>(header >> 8));
  out.push_back(static_cast<char>(header & 0xff));
  for (std::string& part : parts) {
    out += part;
    part = std::string();
  }
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<char>((adler >> shift) & 0xff));
  return out;
}

}  // namespace mvbrdf::store
