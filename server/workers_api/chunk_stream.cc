#include "server/workers_api/chunk_stream.h"

#include <algorithm>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"

namespace mvbrdf::server {
namespace {

grpc::Status ToGrpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace

ChunkStream* ChunkStream::FromFile(const std::filesystem::path& path, const std::string& sha256,
                                   int64_t chunk_bytes) {
  auto* stream = new ChunkStream(chunk_bytes);
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) {
    stream->Finish(ec == std::errc::no_such_file_or_directory
                       ? grpc::Status(grpc::StatusCode::NOT_FOUND, absl::StrCat(path.string(), ": no such file"))
                       : grpc::Status(grpc::StatusCode::INTERNAL, absl::StrCat(path.string(), ": ", ec.message())));
    return stream;
  }
  stream->file_.open(path, std::ios::binary);
  if (!stream->file_) {
    stream->Finish(grpc::Status(grpc::StatusCode::INTERNAL, absl::StrCat(path.string(), ": cannot open")));
    return stream;
  }
  stream->from_file_ = true;
  stream->sha256_ = sha256;
  stream->total_ = static_cast<int64_t>(size);
  stream->Begin();
  return stream;
}

ChunkStream* ChunkStream::FromBytes(std::string bytes, std::string sha256, int64_t chunk_bytes) {
  auto* stream = new ChunkStream(chunk_bytes);
  stream->sha256_ = std::move(sha256);
  stream->total_ = static_cast<int64_t>(bytes.size());
  stream->bytes_ = std::move(bytes);
  stream->Begin();
  return stream;
}

ChunkStream* ChunkStream::Failed(const absl::Status& status) {
  auto* stream = new ChunkStream(1);
  stream->Finish(ToGrpc(status));
  return stream;
}

void ChunkStream::Begin() { WriteNext(); }

void ChunkStream::OnWriteDone(bool ok) {
  if (!ok) {
    Finish(grpc::Status(grpc::StatusCode::CANCELLED, "the fetch ended"));
  } else if (offset_ >= total_) {
    Finish(grpc::Status::OK);
  } else {
    WriteNext();
  }
}

void ChunkStream::WriteNext() {
  // An empty source still gets one chunk: the size and digest.
  const int64_t n = std::min(chunk_bytes_, total_ - offset_);
  chunk_.Clear();
  chunk_.set_offset(static_cast<uint64_t>(offset_));
  if (offset_ == 0) {
    chunk_.set_total_size(static_cast<uint64_t>(total_));
    chunk_.set_sha256(sha256_);
  }
  std::string* data = chunk_.mutable_data();
  if (from_file_) {
    data->resize(static_cast<size_t>(n));
    file_.read(data->data(), static_cast<std::streamsize>(n));
    if (file_.gcount() != n) {
      Finish(grpc::Status(grpc::StatusCode::DATA_LOSS,
                          absl::StrCat(sha256_, ": short read at offset ", offset_, " of ", total_)));
      return;
    }
  } else {
    data->assign(bytes_, static_cast<size_t>(offset_), static_cast<size_t>(n));
  }
  offset_ += n;
  StartWrite(&chunk_);
}

}  // namespace mvbrdf::server
