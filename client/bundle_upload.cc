#include "client/bundle_upload.h"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "absl/strings/str_cat.h"

namespace mvbrdf::client {
namespace {

constexpr size_t kChunkBytes = size_t{1} << 20;

absl::Status FromRpc(const std::string& what, const grpc::Status& status) {
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), absl::StrCat(what, ": ", status.error_message()));
}

// One try: query, then send what the server lacks.
absl::Status UploadOnce(v1::Mvbrdf::Stub& stub, const std::string& client_name, const std::filesystem::path& archive,
                        const std::string& sha256, uint64_t size, ProgressPrinter* progress, UploadOutcome* outcome,
                        uint64_t* server_bytes) {
  *outcome = UploadOutcome();
  v1::UploadStatus upload;
  {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    context.AddMetadata("x-mvbrdf-client", client_name);
    v1::QueryUploadRequest query;
    query.set_sha256(sha256);
    const grpc::Status status = stub.QueryUpload(&context, query, &upload);
    if (!status.ok()) return FromRpc("query upload", status);
  }
  *server_bytes = upload.received_bytes();
  if (upload.complete()) {
    outcome->already_there = true;
    return absl::OkStatus();
  }
  uint64_t offset = upload.received_bytes();
  if (offset > size) offset = 0;  // not ours: the server will say so
  outcome->resumed_at = offset;
  std::ifstream in(archive, std::ios::binary);
  if (!in) return absl::UnavailableError(archive.string() + ": cannot open");
  in.seekg(static_cast<std::streamoff>(offset));
  grpc::ClientContext context;  // no deadline: a bundle may be large
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::UploadStatus uploaded;
  std::unique_ptr<grpc::ClientWriter<v1::UploadChunk>> writer = stub.UploadBundle(&context, &uploaded);
  const int total_mib = static_cast<int>((size + kChunkBytes - 1) / kChunkBytes);
  std::string buffer(kChunkBytes, '\0');
  bool first = true;
  while (offset < size || first) {
    const size_t want = static_cast<size_t>(std::min<uint64_t>(kChunkBytes, size - offset));
    in.read(buffer.data(), static_cast<std::streamsize>(want));
    if (static_cast<size_t>(in.gcount()) != want) return absl::DataLossError(archive.string() + ": short read");
    v1::UploadChunk chunk;
    if (first) {
      chunk.set_sha256(sha256);
      chunk.set_total_size(size);
      first = false;
    }
    chunk.set_offset(offset);
    chunk.set_data(buffer.data(), want);
    if (!writer->Write(chunk)) break;  // the server ended the stream: Finish says why
    offset += want;
    if (progress != nullptr) {
      progress->Update("upload", static_cast<int>((offset + kChunkBytes - 1) / kChunkBytes), total_mib);
    }
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromRpc("upload", status);
  if (!uploaded.complete()) {
    return absl::InternalError(absl::StrCat("upload: the server has ", uploaded.received_bytes(), " of ", size, " bytes"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status UploadBundleFile(v1::Mvbrdf::Stub& stub, const std::string& client_name,
                              const std::filesystem::path& archive, const std::string& sha256, uint64_t size,
                              ProgressPrinter* progress, UploadOutcome* outcome) {
  // The server takes one upload of a bundle at a time (ABORTED for the
  // others). Another client sending the same bytes is common (a team
  // submitting the same sequence), so wait for it: once it completes, the
  // bundle is "already there"; if it stalls, take over from its prefix. Give
  // up only when the server's copy has not grown for kStallLimit.
  constexpr auto kStallLimit = std::chrono::seconds(60);
  auto backoff = std::chrono::milliseconds(100);
  uint64_t last_bytes = 0;
  auto last_growth = std::chrono::steady_clock::now();
  while (true) {
    uint64_t server_bytes = 0;
    absl::Status status = UploadOnce(stub, client_name, archive, sha256, size, progress, outcome, &server_bytes);
    if (!absl::IsAborted(status)) return status;
    const auto now = std::chrono::steady_clock::now();
    if (server_bytes != last_bytes) {
      last_bytes = server_bytes;
      last_growth = now;
    } else if (now - last_growth > kStallLimit) {
      return absl::AbortedError(absl::StrCat(status.message(), " (another upload of this bundle made no progress for ",
                                             kStallLimit.count(), " s)"));
    }
    std::this_thread::sleep_for(backoff);
    backoff = std::min(backoff * 2, std::chrono::milliseconds(1000));
  }
}

}  // namespace mvbrdf::client
