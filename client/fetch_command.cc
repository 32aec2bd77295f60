// `mvbrdf fetch JOB NAME... --server HOST:PORT --out DIR`: downloads a job's
// artifacts to DIR/NAME, each verified against the SHA-256 the server sends.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/connection.h"
#include "client/flags.h"
#include "client/output_dir.h"
#include "core/bundle/sha256.h"
#include "core/scene/names.h"
#include "mvbrdf/v1/service.grpc.pb.h"

namespace mvbrdf::client {
namespace {

// Why `name` cannot place a file under DIR (empty when it can): relative,
// no "..", no empty component. A trailing "/" names a directory of artifacts
// (e.g. "atlases/"), which the caller expands.
std::string WhyNotSafeName(const std::string& name) {
  if (name.empty() || name == "/") return "must not be empty";
  const std::filesystem::path path(name);
  if (path.has_root_path()) return "must be a relative path (artifact names are relative to the job's output)";
  for (const std::filesystem::path& part : std::filesystem::path(name).relative_path()) {
    if (part == "..") return "must be a relative path without \"..\" (inside --out)";
  }
  return "";
}

// Value flags of `fetch` (their values are not names).
bool TakesValue(const std::string& arg) {
  return arg == "--server" || arg == "--client" || arg == "--out" || arg == "--token-file" || arg == "--tls-ca" ||
         arg == "--tls-cert" || arg == "--tls-key" || arg == "--tls-server-name";
}

// Returns kExitOk or the exit code after printing the error.
int FetchOne(v1::Mvbrdf::Stub& stub, const std::shared_ptr<grpc::Channel>& channel, const std::string& client_name,
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
  if (!status.ok()) {
    std::string message = status.error_message();
    if (status.error_code() == grpc::StatusCode::NOT_FOUND && absl::StartsWith(message, "name:")) {
      // The job exists but has no such artifact: say which names it has.
      v1::ListArtifactsResponse listed;
      if (ListJobArtifacts(channel, client_name, job_id, &listed).ok()) {
        std::string under, all;
        for (const v1::ArtifactReady& a : listed.artifacts()) {
          all += (all.empty() ? "" : ", ") + a.name();
          if (a.name().compare(0, name.size() + 1, name + "/") == 0) under += (under.empty() ? "" : ", ") + a.name();
        }
        message += under.empty()
                       ? "; its artifacts: " + all
                       : "; it is a directory of artifacts (fetch \"" + name + "/\" for all of them): " + under;
      }
    }
    return fail(message, ExitCodeForRpc(status.error_code()));
  }
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

// The names to fetch: every artifact for --all, and for a name ending in "/"
// (or one the job does not have that is a directory of artifacts) every
// artifact under it. On a name that matches nothing, prints which exist.
int ExpandNames(const std::shared_ptr<grpc::Channel>& channel, const std::string& client_name,
                const std::string& job_id, bool all, std::vector<std::string>* names) {
  const bool has_prefix =
      all || std::any_of(names->begin(), names->end(), [](const std::string& n) { return n.back() == '/'; });
  if (!has_prefix) return kExitOk;  // plain names: fetched as given (also from a running job)
  v1::ListArtifactsResponse listed;
  const grpc::Status status = ListJobArtifacts(channel, client_name, job_id, &listed);
  if (!status.ok()) {
    std::fprintf(stderr, "mvbrdf fetch: error: %s: %s\n", scene::ShownName(job_id).c_str(),
                 scene::ShownName(status.error_message()).c_str());
    return ExitCodeForRpc(status.error_code());
  }
  std::vector<std::string> expanded;
  if (all) {
    for (const v1::ArtifactReady& a : listed.artifacts()) expanded.push_back(a.name());
  }
  for (const std::string& name : *names) {
    if (name.back() != '/') {
      expanded.push_back(name);
      continue;
    }
    size_t matched = 0;
    for (const v1::ArtifactReady& a : listed.artifacts()) {
      if (a.name().compare(0, name.size(), name) == 0) {
        expanded.push_back(a.name());
        ++matched;
      }
    }
    if (matched == 0) {
      std::string known;
      for (const v1::ArtifactReady& a : listed.artifacts()) known += "\n  " + scene::ShownName(a.name());
      std::fprintf(stderr, "mvbrdf fetch: error: %s: job %s has no artifact under \"%s\"; its artifacts are:%s\n",
                   scene::ShownName(name).c_str(), scene::ShownName(job_id).c_str(), scene::ShownName(name).c_str(),
                   known.c_str());
      return kExitInvalidInput;
    }
  }
  // Each once, in name order.
  std::sort(expanded.begin(), expanded.end());
  expanded.erase(std::unique(expanded.begin(), expanded.end()), expanded.end());
  *names = std::move(expanded);
  return kExitOk;
}

}  // namespace

int RunFetch(const std::vector<std::string>& args) {
  std::string job_id, first_name, address, client_name = "anonymous", out_dir;
  bool all = false;
  FlagParser flags("fetch",
                   "Downloads artifacts of a job (names as 'mvbrdf artifacts JOB' lists them, e.g. atlases/kd.exr; "
                   "a name ending in \"/\" such as atlases/ fetches everything under it; --all fetches every one) "
                   "to DIR/NAME, each through a temporary renamed into place after its SHA-256 was verified. Exit "
                   "code 3 when the job or an artifact does not exist (the job's artifact names are listed), 4 "
                   "when the server is unreachable or DIR cannot be written.");
  flags.AddPositional("JOB", &job_id, true, "the job id");
  flags.AddPositional("NAME...", &first_name, false,
                      "artifact names (relative paths without \"..\"; DIR/ for a directory of them)");
  flags.AddBool("--all", &all, "fetch every artifact of the job (a succeeded job), keeping their relative paths");
  flags.AddString("--server ADDR", &address, "the server, host:port (required)");
  flags.AddString("--client NAME", &client_name, "the client name sent to the server (without tokens)");
  ConnectionFlags connection;
  AddConnectionFlags(flags, &connection);
  flags.AddString("--out DIR", &out_dir,
                  "the directory to write to (required; created when missing, refused when not empty)");
  bool force = false;
  flags.AddBool("--force", &force, kForceHelp);
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
  if (positionals >= 2) names.insert(names.begin(), first_name);
  if (all == !names.empty()) {
    std::fprintf(stderr, "mvbrdf fetch: %s\n",
                 all ? "--all: fetches every artifact; give no NAME with it"
                     : "NAME...: required (an artifact name, a directory such as atlases/, or --all)");
    return kExitUsage;
  }
  for (const std::string& name : names) {
    if (const std::string why = WhyNotSafeName(name); !why.empty()) {
      std::fprintf(stderr, "mvbrdf fetch: NAME \"%s\": %s\n", scene::ShownName(name).c_str(), why.c_str());
      return kExitUsage;
    }
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = OpenChannel(address, connection);
  if (!channel.ok()) {
    std::fprintf(stderr, "mvbrdf fetch: %s\n", std::string(channel.status().message()).c_str());
    return kExitUsage;
  }
  if (int code = ExpandNames(*channel, client_name, job_id, all, &names); code != kExitOk) return code;
  absl::StatusOr<OutputDirLock> lock = PrepareOutputDir("--out", out_dir, force);
  if (!lock.ok()) return ReportFailure(lock.status(), "mvbrdf fetch");
  auto stub = v1::Mvbrdf::NewStub(*channel);
  for (const std::string& name : names) {
    if (int code = FetchOne(*stub, *channel, client_name, job_id, name, out_dir); code != kExitOk) return code;
  }
  return kExitOk;
}

}  // namespace mvbrdf::client
