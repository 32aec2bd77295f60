// `mvbrdf submit SCENE --server HOST:PORT [...]`: packs the scene's bundle,
// uploads what the server does not have yet (resuming a partial upload) and
// queues a job; with --watch follows it like `mvbrdf watch`.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/strings/str_split.h"
#include "client/commands.h"
#include "client/flags.h"
#include "client/progress.h"
#include "core/base/proto_json.h"
#include "core/bundle/bundle.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {
namespace {

constexpr size_t kChunkBytes = size_t{1} << 20;

// Removes the temporary bundle on every path out of RunSubmit.
class TempFile {
 public:
  explicit TempFile(std::filesystem::path path) : path_(std::move(path)) {}
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

int LocalFailure(const absl::Status& status) { return ReportFailure(status, "mvbrdf submit"); }

int RpcFailure(const std::string& what, const std::string& address, const grpc::Status& status) {
  std::fprintf(stderr, "mvbrdf submit: error: %s %s: %s\n", what.c_str(), address.c_str(),
               status.error_message().c_str());
  return ExitCodeForRpc(status.error_code());
}

bool ParseOutputs(const std::string& text, v1::SubmitJobRequest* request) {
  if (text.empty()) return true;
  for (absl::string_view name : absl::StrSplit(text, ',')) {
    if (name == "light") {
      request->add_outputs(v1::OUTPUT_LIGHT_TABLE);
    } else if (name == "brdf") {
      request->add_outputs(v1::OUTPUT_BRDF_ATLASES);
    } else if (name == "correction") {
      request->add_outputs(v1::OUTPUT_CORRECTION);
    } else if (name == "errors") {
      request->add_outputs(v1::OUTPUT_CAMERA_ERRORS);
    } else {
      std::fprintf(stderr, "mvbrdf submit: --outputs: unknown output \"%s\" (light, brdf, correction, errors)\n",
                   std::string(name).c_str());
      return false;
    }
  }
  return true;
}

std::chrono::system_clock::time_point Deadline() {
  return std::chrono::system_clock::now() + std::chrono::seconds(30);
}

}  // namespace

int RunSubmit(const std::vector<std::string>& args) {
  std::string scene, address, client_name = "anonymous", outputs, config;
  bool json = false, watch = false;
  FlagParser flags("submit",
                   "Packs SCENE and the files it names into a bundle, uploads the bytes the server does not have "
                   "yet, queues a job and prints its id. With --watch, then follows the job like 'mvbrdf watch' "
                   "(exit code 0 succeeded, 5 failed, 6 cancelled).");
  flags.AddPositional("SCENE", &scene, true, "the scene file (scene.json)");
  flags.AddString("--server", &address, "the server, host:port (required)");
  flags.AddString("--client", &client_name, "the client name the job is submitted as");
  flags.AddString("--outputs", &outputs, "comma-separated: light,brdf,correction,errors (default: all)");
  flags.AddString("--config", &config, "a known light configuration: no sweep (default: sweep the scene's)");
  flags.AddBool("--watch", &watch, "follow the job's events until it ends");
  flags.AddBool("--json", &json, "print the SubmitJobResponse as JSON (and with --watch each event as a JSON line)");
  if (absl::Status s = flags.Parse(args); !s.ok()) {
    std::fprintf(stderr, "mvbrdf submit: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (address.empty()) {
    std::fprintf(stderr, "mvbrdf submit: --server: required\n");
    return kExitUsage;
  }
  v1::SubmitJobRequest submit;
  if (!ParseOutputs(outputs, &submit)) return kExitUsage;
  submit.set_configuration(config);
  submit.set_scene_path(std::filesystem::path(scene).filename().string());

  // The bundle, in a private temporary file.
  std::error_code ec;
  std::filesystem::path tmp_dir = std::filesystem::temp_directory_path(ec);
  if (ec) tmp_dir = "/tmp";
  std::random_device random;
  const TempFile archive(tmp_dir / ("mvbrdf-submit-" + std::to_string(getpid()) + "-" +
                                    std::to_string(random()) + ".tar"));
  absl::StatusOr<bundle::BundleInfo> info = bundle::PackBundle(scene, archive.path());
  if (!info.ok()) return LocalFailure(info.status());
  submit.set_bundle_sha256(info->sha256);

  auto stub = v1::Mvbrdf::NewStub(grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  v1::UploadStatus upload;
  {
    grpc::ClientContext context;
    context.set_deadline(Deadline());
    context.AddMetadata("x-mvbrdf-client", client_name);
    v1::QueryUploadRequest query;
    query.set_sha256(info->sha256);
    const grpc::Status status = stub->QueryUpload(&context, query, &upload);
    if (!status.ok()) return RpcFailure("query upload on", address, status);
  }
  const uint64_t total = static_cast<uint64_t>(info->size);
  if (upload.complete()) {
    std::fprintf(stderr, "bundle already on the server (%s, %llu bytes)\n", info->sha256.c_str(),
                 static_cast<unsigned long long>(total));
  } else {
    uint64_t offset = upload.received_bytes();
    if (offset > total) offset = 0;  // not ours: the server will say so
    if (offset > 0) {
      std::fprintf(stderr, "resuming the upload at %llu of %llu bytes\n", static_cast<unsigned long long>(offset),
                   static_cast<unsigned long long>(total));
    }
    std::ifstream in(archive.path(), std::ios::binary);
    if (!in) return LocalFailure(absl::UnavailableError(archive.path().string() + ": cannot open"));
    in.seekg(static_cast<std::streamoff>(offset));
    grpc::ClientContext context;  // no deadline: a bundle may be large
    context.AddMetadata("x-mvbrdf-client", client_name);
    v1::UploadStatus uploaded;
    std::unique_ptr<grpc::ClientWriter<v1::UploadChunk>> writer = stub->UploadBundle(&context, &uploaded);
    ProgressPrinter progress(stderr);
    const int total_mib = static_cast<int>((total + kChunkBytes - 1) / kChunkBytes);
    std::string buffer(kChunkBytes, '\0');
    bool first = true;
    while (offset < total || first) {
      const size_t want = static_cast<size_t>(std::min<uint64_t>(kChunkBytes, total - offset));
      in.read(buffer.data(), static_cast<std::streamsize>(want));
      if (static_cast<size_t>(in.gcount()) != want) {
        return LocalFailure(absl::DataLossError(archive.path().string() + ": short read"));
      }
      v1::UploadChunk chunk;
      if (first) {
        chunk.set_sha256(info->sha256);
        chunk.set_total_size(total);
        first = false;
      }
      chunk.set_offset(offset);
      chunk.set_data(buffer.data(), want);
      if (!writer->Write(chunk)) break;  // the server ended the stream: Finish says why
      offset += want;
      progress.Update("upload", static_cast<int>((offset + kChunkBytes - 1) / kChunkBytes), total_mib);
    }
    writer->WritesDone();
    const grpc::Status status = writer->Finish();
    if (!status.ok()) return RpcFailure("upload to", address, status);
    if (!uploaded.complete()) {
      std::fprintf(stderr, "mvbrdf submit: error: upload to %s: the server has %llu of %llu bytes\n",
                   address.c_str(), static_cast<unsigned long long>(uploaded.received_bytes()),
                   static_cast<unsigned long long>(total));
      return kExitInternal;
    }
  }

  v1::SubmitJobResponse response;
  {
    grpc::ClientContext context;
    context.set_deadline(Deadline());
    context.AddMetadata("x-mvbrdf-client", client_name);
    const grpc::Status status = stub->SubmitJob(&context, submit, &response);
    if (!status.ok()) return RpcFailure("submit to", address, status);
  }
  if (json) {
    std::printf("%s\n", MessageToJson(response).c_str());
  } else {
    std::printf("%s\n", response.job().id().c_str());
  }
  std::fflush(stdout);
  if (!watch) return kExitOk;
  return WatchJobEvents("submit", address, client_name, response.job().id(), json);
}

}  // namespace mvbrdf::client
