// `mvbrdf fetch JOB NAME... --server HOST:PORT --out DIR`: downloads a job's
// artifacts to DIR/NAME, each verified against the SHA-256 the server sends.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "core/bundle/sha256.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {
namespace {

// A name may only place a file under DIR: relative, no "..", no empty name.
bool SafeName(const std::string& name) {
  if (name.empty()) return false;
  const std::filesystem::path path(name);
  if (path.has_root_path() || !path.has_filename()) return false;
  for (const std::filesystem::path& part : path) {
    if (part == "..") return false;
  }
  return true;
}

// Value flags of `fetch` (their values are not names).
bool TakesValue(const std::string& arg) {
  return arg == "--server" || arg == "--client" || arg == "--out" || arg == "--token-file" || arg == "--tls-ca" ||
         arg == "--tls-cert" || arg == "--tls-key" || arg == "--tls-server-name";
}

// Returns kExitOk or the exit code after printing the error.
int FetchOne(v1::Mvbrdf::Stub& stub, const std::string& address, const std::string& client_name,
             const std::string& job_id, const std::string& name, const std::filesystem::path& out_dir) {
  const std::filesystem::path target = out_dir / name;
  std::filesystem::path part = target;
  part += ".part";
  std::error_code ec;
  std::filesystem::create_directories(target.parent_path(), ec);
  if (ec) {
    std::fprintf(stderr, "mvbrdf fetch: error: %s: %s\n", target.parent_path().c_str(), ec.message().c_str());
    return kExitEnvironment;
  }
  grpc::ClientContext context;  // no deadline: artifacts may be large
  context.AddMetadata("x-mvbrdf-client", client_name);
  v1::FetchArtifactRequest request;
  request.set_job_id(job_id);
  request.set_name(name);
  std::unique_ptr<grpc::ClientReader<v1::ArtifactChunk>> reader = stub.FetchArtifact(&context, request);
  std::ofstream out;
  bool first = true;
  uint64_t received = 0, total = 0;
  std::string sha256, local_error;
  int write_errno = 0;
  v1::ArtifactChunk chunk;
  while (reader->Read(&chunk)) {
    if (first) {
      first = false;
      total = chunk.total_size();
      sha256 = absl::AsciiStrToLower(chunk.sha256());
      errno = 0;
      out.open(part, std::ios::binary | std::ios::trunc);
      if (!out) {
        write_errno = errno;
        local_error = part.string() + ": cannot write";
        context.TryCancel();
        break;
      }
    }
    if (chunk.offset() != received) {
      local_error = "chunk at offset " + std::to_string(chunk.offset()) + ", expected " + std::to_string(received);
      context.TryCancel();
      break;
    }
    errno = 0;
    out.write(chunk.data().data(), static_cast<std::streamsize>(chunk.data().size()));
    if (!out) {
      // A full disk said "write failed" without why (exit 4 either way).
      write_errno = errno;
      local_error = part.string() + ": write failed";
      context.TryCancel();
      break;
    }
    received += chunk.data().size();
  }
  const grpc::Status status = reader->Finish();
  if (out.is_open()) {
    errno = 0;
    out.close();
    if (!out && local_error.empty()) {
      write_errno = errno;
      local_error = part.string() + ": write failed";
    }
  }
  auto fail = [&](const std::string& message, int code) {
    std::filesystem::remove(part, ec);
    std::fprintf(stderr, "mvbrdf fetch: error: %s %s: %s\n", scene::ShownName(job_id).c_str(),
                 scene::ShownName(name).c_str(), scene::ShownName(message).c_str());
    return code;
  };
  if (!local_error.empty()) {
    if (write_errno != 0) local_error += absl::StrCat(": ", std::strerror(write_errno));
    return fail(local_error, kExitEnvironment);
  }
  if (!status.ok()) return fail(status.error_message(), ExitCodeForRpc(status.error_code()));
  if (first) {
    // An empty artifact still sends one chunk; nothing at all is a server bug.
    return fail("the server sent no data", kExitInternal);
  }
  if (received != total) {
    return fail("received " + std::to_string(received) + " of " + std::to_string(total) + " bytes", kExitInternal);
  }
  absl::StatusOr<std::string> actual = bundle::Sha256File(part);
  if (!actual.ok()) return fail(std::string(actual.status().message()), kExitEnvironment);
  if (*actual != sha256) return fail("sha256 mismatch: expected " + sha256 + ", got " + *actual, kExitInternal);
  std::filesystem::rename(part, target, ec);
  if (ec) return fail(target.string() + ": " + ec.message(), kExitEnvironment);
  std::printf("%s  %llu bytes  sha256 %s\n", target.c_str(), static_cast<unsigned long long>(total), sha256.c_str());
  return kExitOk;
}

}  // namespace

int RunFetch(const std::vector<std::string>& args) {
  std::string job_id, first_name, address, client_name = "anonymous", out_dir;
  FlagParser flags("fetch",
                   "Downloads artifacts of a job (names as 'mvbrdf watch' lists them, e.g. atlases/kd.exr) to "
                   "DIR/NAME, verifying each one's SHA-256. Exit code 3 when the job or an artifact does not exist.");
  flags.AddPositional("JOB", &job_id, true, "the job id");
  flags.AddPositional("NAME...", &first_name, true, "artifact names: relative paths without \"..\"");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name sent to the server (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddString("--out DIR", &out_dir, "the directory to write to (required; created when missing)");
  // FlagParser takes a fixed number of positionals: pass it JOB and the first
  // NAME, keep the other names here.
  std::vector<std::string> parsed, names;
  int positionals = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      parsed.push_back(arg);
      if (TakesValue(arg) && i + 1 < args.size()) parsed.push_back(args[++i]);
    } else if (arg == "-h") {
      parsed.push_back(arg);
    } else if (positionals++ < 2) {
      parsed.push_back(arg);
    } else {
      names.push_back(arg);
    }
  }
  if (absl::Status s = flags.Parse(parsed); !s.ok()) {
    std::fprintf(stderr, "mvbrdf fetch: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (flags.help_requested()) {
    std::fputs(flags.Usage().c_str(), stdout);
    return kExitOk;
  }
  if (absl::Status s = CheckLabel(client_name, "--client"); !s.ok()) {
    std::fprintf(stderr, "mvbrdf fetch: %s\n", std::string(s.message()).c_str());
    return kExitUsage;
  }
  if (address.empty() || out_dir.empty()) {
    std::fprintf(stderr, "mvbrdf fetch: %s: required\n", address.empty() ? "--server" : "--out");
    return kExitUsage;
  }
  names.insert(names.begin(), first_name);
  for (const std::string& name : names) {
    if (!SafeName(name)) {
      std::fprintf(stderr, "mvbrdf fetch: NAME \"%s\": must be a relative path without \"..\"\n",
                   scene::ShownName(name).c_str());
      return kExitUsage;
    }
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf fetch: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  auto stub = v1::Mvbrdf::NewStub(*channel);
  for (const std::string& name : names) {
    if (int code = FetchOne(*stub, address, client_name, job_id, name, out_dir); code != kExitOk) return code;
  }
  return kExitOk;
}

}  // namespace mvbrdf::client
