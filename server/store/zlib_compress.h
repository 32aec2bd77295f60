// zlib (RFC 1950) compression of large blobs on several threads, for the
// Sample cache (issue #17): `mvbrdf run` at 40 frames spent ~2.5 s of one
// core compressing 136 MB of gathered Samples (zlib level 1, ~55 MB/s on
// this machine) while the job waited for it and the other core idled.
//
// The input is cut into chunks deflated independently (raw deflate, no
// dictionary from the chunk before), each but the last ending on a byte
// boundary (Z_SYNC_FLUSH) and the last with the final block (Z_FINISH), as
// pigz does: their concatenation behind a zlib header, with the Adler-32 of
// the whole (adler32_combine of the chunks'), is one valid zlib stream that
// uncompress() reads like compress2()'s. An input of one chunk is
// compress2()'s output byte for byte.
#ifndef MVBRDF_SERVER_STORE_ZLIB_COMPRESS_H_
#define MVBRDF_SERVER_STORE_ZLIB_COMPRESS_H_

#include <cstddef>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::store {

struct ZlibCompressOptions {
  int level = 1;                              // 1..9, as compress2
  size_t chunk_bytes = size_t{8} << 20;       // per independently deflated chunk (> 0)
  int threads = 0;                            // 0: std::thread::hardware_concurrency()
};

absl::StatusOr<std::string> ZlibCompress(absl::string_view bytes, const ZlibCompressOptions& options = {});

}  // namespace mvbrdf::store

#endif  // MVBRDF_SERVER_STORE_ZLIB_COMPRESS_H_
