// A server-streaming reply of ArtifactChunks (callback API): the bytes of a
// file or of a buffer in chunks of at most `chunk_bytes`, the first chunk
// carrying total_size and sha256. What FetchBundle and FetchSamples send.
//
// Ownership: gRPC owns the reactor; it deletes itself in OnDone. The file is
// read one chunk at a time on gRPC's threads (never all of it in memory).
#ifndef MVBRDF_SERVER_WORKERS_API_CHUNK_STREAM_H_
#define MVBRDF_SERVER_WORKERS_API_CHUNK_STREAM_H_

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include <grpcpp/grpcpp.h>

#include "absl/status/status.h"
#include "mvbrdf/v1/service.pb.h"

namespace mvbrdf::server {

class ChunkStream final : public grpc::ServerWriteReactor<v1::ArtifactChunk> {
 public:
  // The file at `path` (`sha256`: its known digest, sent as is). NOT_FOUND
  // when the file is missing.
  static ChunkStream* FromFile(const std::filesystem::path& path, const std::string& sha256, int64_t chunk_bytes);
  // `bytes` (`sha256`: their known digest, sent as is).
  static ChunkStream* FromBytes(std::string bytes, std::string sha256, int64_t chunk_bytes);
  // A stream that only finishes with `status` (not OK).
  static ChunkStream* Failed(const absl::Status& status);

  void OnWriteDone(bool ok) override;
  void OnDone() override { delete this; }

 private:
  explicit ChunkStream(int64_t chunk_bytes) : chunk_bytes_(chunk_bytes) {}
  // Sends the first chunk, or finishes OK at once for an empty source.
  void Begin();
  void WriteNext();

  const int64_t chunk_bytes_;
  bool from_file_ = false;
  std::ifstream file_;
  std::string bytes_;  // when !from_file_
  std::string sha256_;
  int64_t total_ = 0;
  int64_t offset_ = 0;
  v1::ArtifactChunk chunk_;
};

}  // namespace mvbrdf::server

#endif  // MVBRDF_SERVER_WORKERS_API_CHUNK_STREAM_H_
