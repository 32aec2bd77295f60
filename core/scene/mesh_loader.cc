#include "core/scene/mesh_loader.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/files.h"
#include "core/base/sanitizers.h"
#include "core/scene/obj_reader.h"

namespace mvbrdf::scene {
namespace {

// UVs may sit a rounding error outside [0,1] after an exporter's arithmetic;
// such UVs are clamped without being listed.
constexpr float kUvTolerance = 1e-6f;
// A triangle whose area is below this fraction of the squared bounding-box
// diagonal is degenerate: it has no well-defined normal or texel footprint.
constexpr double kZeroAreaRelative = 1e-12;

// Bit pattern of a float, so that welding compares exactly (no epsilon, and
// +0 / -0 stay distinct, as they are distinct file values).
uint32_t Bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof(u));
  return u;
}

struct Key3 {
  uint32_t x, y, z;
  bool operator==(const Key3& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct Key3Hash {
  size_t operator()(const Key3& k) const {
    uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) ^ (k.y * 0xBF58476D1CE4E5B9ull);
    h ^= (h >> 31) ^ (k.z * 0x94D049BB133111EBull);
    return static_cast<size_t>(h ^ (h >> 32));
  }
};

std::string Prefix(absl::string_view field, const std::filesystem::path& file) {
  return absl::StrCat(field, ": ", file.string());
}

// A face corner as assimp gives it, in file order.
struct Corner {
  aiVector3D position;
  aiVector3D uv;  // (0,0,0) when the mesh has no UVs
};

// All triangle corners of a file (3 per triangle, file order) and whether they
// carry UVs. Points and lines (faces with fewer than 3 indices) are skipped:
// they are not surface.
struct ImportedCorners {
  std::vector<Corner> corners;
  bool has_uvs = false;
};

// assimp opens more than the file it is given: an OBJ's `mtllib`, a glTF's
// buffer `uri`. Those names come from the file, i.e. from whoever sent the
// bundle, so every open is confined to the mesh file's directory (after
// resolving "..", and symbolic links): a mesh cannot make the server or a
// worker read /etc/passwd or another job's files.
class ConfinedIOSystem final : public Assimp::DefaultIOSystem {
 public:
  explicit ConfinedIOSystem(const std::filesystem::path& dir) : root_(Resolve(dir)) {}

  bool Exists(const char* file) const override { return Inside(file) && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    // Read-only, and only inside.
    if (mode == nullptr || std::string_view(mode).find_first_of("wa+") != std::string_view::npos) return nullptr;
    return Inside(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
  }

 private:
  static std::filesystem::path Resolve(const std::filesystem::path& path) {
    std::error_code ec;
    std::filesystem::path resolved = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec), ec);
    return ec ? std::filesystem::path() : resolved;
  }
  bool Inside(const char* file) const {
    if (file == nullptr || root_.empty()) return false;
    const std::filesystem::path resolved = Resolve(file);
    if (resolved.empty()) return false;
    auto [r, f] = std::mismatch(root_.begin(), root_.end(), resolved.begin(), resolved.end());
    return r == root_.end() && f != resolved.end();
  }

  const std::filesystem::path root_;
};

// Runs assimp on `file` in this process (see ImportCorners).
absl::StatusOr<ImportedCorners> ImportCornersHere(const std::filesystem::path& file, absl::string_view field) {
  Assimp::Importer importer;
  importer.SetIOHandler(new ConfinedIOSystem(file.parent_path().empty() ? "." : file.parent_path()));  // owned by importer
  // Validation first (it rejects faces without indices and indices past the
  // vertex array, which the corner loop below would read out of bounds), then
  // triangulation only: no welding (we weld bit-exactly ourselves, keeping
  // file order) and no sorting by primitive type (which would reorder faces).
  const aiScene* scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure);
  if (scene == nullptr || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix(field, file), ": cannot read mesh: ", importer.GetErrorString()));
  }
  // Our own checks before triangulating, as assimp's validation lets a face
  // without indices through and Debian's assimp is built with assertions: a
  // PLY face list of length 0 made triangulation abort the process (found by
  // tests/fuzz/mesh_loader_fuzz). An index past the vertex array would make
  // the corner loop below read out of bounds. The primitive types, which
  // triangulation trusts, are recomputed from the faces.
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    aiMesh* mesh = scene->mMeshes[m];
    if (mesh == nullptr) {
      return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": mesh ", m, " is missing"));
    }
    if (mesh->mNumFaces != 0 && (mesh->mFaces == nullptr || mesh->mVertices == nullptr)) {
      return absl::InvalidArgumentError(
          absl::StrCat(Prefix(field, file), ": mesh ", m, " has faces but no face or vertex array"));
    }
    unsigned types = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices == 0 || face.mIndices == nullptr) {
        return absl::InvalidArgumentError(
            absl::StrCat(Prefix(field, file), ": mesh ", m, " face ", f, " has no vertex indices"));
      }
      for (unsigned k = 0; k < face.mNumIndices; ++k) {
        if (face.mIndices[k] >= mesh->mNumVertices) {
          return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": mesh ", m, " face ", f,
                                                         " refers to vertex ", face.mIndices[k], " of ",
                                                         mesh->mNumVertices));
        }
      }
      const unsigned n = face.mNumIndices;
      types |= n == 1   ? aiPrimitiveType_POINT
               : n == 2 ? aiPrimitiveType_LINE
               : n == 3 ? aiPrimitiveType_TRIANGLE
                        : aiPrimitiveType_POLYGON;
    }
    mesh->mPrimitiveTypes = types;
  }
  scene = importer.ApplyPostProcessing(aiProcess_Triangulate);
  if (scene == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(Prefix(field, file), ": cannot triangulate mesh: ", importer.GetErrorString()));
  }
  ImportedCorners out;
  size_t meshes_with_uvs = 0, meshes_with_faces = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    size_t triangles = 0;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) triangles += mesh->mFaces[f].mNumIndices == 3 ? 1 : 0;
    if (triangles == 0) continue;
    ++meshes_with_faces;
    if (mesh->HasTextureCoords(0)) ++meshes_with_uvs;
  }
  if (meshes_with_uvs != 0 && meshes_with_uvs != meshes_with_faces) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": ", meshes_with_uvs, " of ",
                                                   meshes_with_faces,
                                                   " meshes have texture coordinates; expected all or none"));
  }
  out.has_uvs = meshes_with_uvs != 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    const aiVector3D* uvs = mesh->mTextureCoords[0];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) {
        const unsigned i = face.mIndices[k];
        Corner c;
        c.position = mesh->mVertices[i];
        if (uvs != nullptr) c.uv = uvs[i];
        out.corners.push_back(c);
      }
    }
  }
  if (out.corners.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": mesh has no triangles"));
  }
  return out;
}

// The importer runs in a child process. Assimp (Debian's 5.2, not ours to
// fix) crashes on some malformed files — tests/fuzz/mesh_loader_fuzz finds
// segfaults in its PLY reader within seconds — and a mesh comes from a
// request's bundle, so a crash must fail that load, not take down the server
// or worker. The child sends the corners back through a pipe:
//   'C', has_uvs (u8), then per corner 5 x f32 (x, y, z, u, v), then "END."
//   'E', status code (u32), message bytes, then "END."
// (native byte order: the same machine). The parent checks the framing, so a
// child that dies part-way is an error whatever its exit status says.
constexpr char kTrailer[4] = {'E', 'N', 'D', '.'};
// Assimp also loops forever on some malformed files (a PLY header, found by
// the fuzzer): the child gets kImportSeconds plus kImportSecondsPerMiB per MiB
// of file, far more than assimp needs (samba: 1 MiB in 10 ms).
constexpr double kImportSeconds = 5.0;
constexpr double kImportSecondsPerMiB = 1.0;
// Memory the importer may add to the process (see ImportCorners).
constexpr double kImportMemoryBytes = 2.0 * (1 << 30);
constexpr double kImportMemoryPerFileByte = 64.0;
std::atomic<double> import_seconds{kImportSeconds};
std::atomic<double> import_seconds_per_mib{kImportSecondsPerMiB};

std::string EncodeImport(const absl::StatusOr<ImportedCorners>& result) {
  std::string out;
  if (!result.ok()) {
    const uint32_t code = static_cast<uint32_t>(result.status().code());
    out.push_back('E');
    out.append(reinterpret_cast<const char*>(&code), sizeof(code));
    out.append(result.status().message().data(), result.status().message().size());
  } else {
    out.reserve(2 + result->corners.size() * 5 * sizeof(float) + sizeof(kTrailer));
    out.push_back('C');
    out.push_back(result->has_uvs ? 1 : 0);
    for (const Corner& c : result->corners) {
      const float v[5] = {c.position.x, c.position.y, c.position.z, c.uv.x, c.uv.y};
      out.append(reinterpret_cast<const char*>(v), sizeof(v));
    }
  }
  out.append(kTrailer, sizeof(kTrailer));
  return out;
}

absl::StatusOr<ImportedCorners> DecodeImport(absl::string_view data, const std::string& prefix) {
  const auto broken = [&] {
    return absl::InternalError(absl::StrCat(prefix, ": the mesh importer process sent a malformed reply"));
  };
  if (data.size() < 1 + sizeof(kTrailer) ||
      std::memcmp(data.data() + data.size() - sizeof(kTrailer), kTrailer, sizeof(kTrailer)) != 0) {
    return broken();
  }
  data.remove_suffix(sizeof(kTrailer));
  if (data[0] == 'E') {
    uint32_t code = 0;
    if (data.size() < 1 + sizeof(code)) return broken();
    std::memcpy(&code, data.data() + 1, sizeof(code));
    if (code == 0 || code > static_cast<uint32_t>(absl::StatusCode::kUnauthenticated)) return broken();
    return absl::Status(static_cast<absl::StatusCode>(code), data.substr(1 + sizeof(code)));
  }
  constexpr size_t kCornerBytes = 5 * sizeof(float);
  if (data[0] != 'C' || data.size() < 2 || (data.size() - 2) % kCornerBytes != 0) return broken();
  ImportedCorners out;
  out.has_uvs = data[1] != 0;
  const size_t n = (data.size() - 2) / kCornerBytes;
  out.corners.resize(n);
  for (size_t i = 0; i < n; ++i) {
    float v[5];
    std::memcpy(v, data.data() + 2 + i * kCornerBytes, kCornerBytes);
    out.corners[i].position = aiVector3D(v[0], v[1], v[2]);
    out.corners[i].uv = aiVector3D(v[3], v[4], 0.0f);
  }
  return out;
}

// Bytes of a PLY scalar type in a binary file; 0 for an unknown name.
size_t PlyScalarBytes(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

// A PLY header's element counts against the bytes that follow it. Assimp
// allocates what the header declares before reading the body: a 150-byte
// ASCII PLY declaring 400 million vertices took 4.7 GB and minutes (a
// hand-made input, written while reviewing the fuzzer's PLY findings). Each
// element needs at least its scalars' bytes (binary) or 2 bytes per property
// (ASCII: a digit and a separator), a list at least its count. Headers we
// cannot follow are left to assimp.
absl::Status CheckPlyCounts(const std::filesystem::path& file, const std::string& prefix) {
  std::ifstream in(file, std::ios::binary);
  std::string head(size_t{1} << 16, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  if (head.rfind("ply", 0) != 0) return absl::OkStatus();
  const size_t end = head.find("end_header");
  if (end == std::string::npos) return absl::OkStatus();
  const size_t body_start = head.find('\n', end);
  if (body_start == std::string::npos) return absl::OkStatus();
  std::error_code ec;
  const uintmax_t file_size = std::filesystem::file_size(file, ec);
  if (ec || file_size < body_start + 1) return absl::OkStatus();
  const double body = static_cast<double>(file_size - (body_start + 1));

  struct Element {
    std::string name;
    double count = 0;
    double min_bytes = 0;
  };
  std::vector<Element> elements;
  bool ascii = false;
  std::istringstream lines(head.substr(0, end));
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string keyword, a, b;
    words >> keyword >> a >> b;
    if (keyword == "format") {
      ascii = a == "ascii";
    } else if (keyword == "element") {
      uint64_t count = 0;
      if (!absl::SimpleAtoi(b, &count)) return absl::OkStatus();
      elements.push_back({a, static_cast<double>(count), 0});
    } else if (keyword == "property" && !elements.empty()) {
      const size_t bytes = PlyScalarBytes(a == "list" ? b : a);
      if (bytes == 0) return absl::OkStatus();
      elements.back().min_bytes += ascii ? 2.0 : static_cast<double>(bytes);
    }
  }
  double needed = 0;
  for (const Element& e : elements) {
    needed += e.count * std::max(1.0, e.min_bytes);
    if (needed > body) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "%s: cannot read mesh: the PLY header declares %.0f \"%s\" elements, more than the %.0f bytes after the "
          "header can hold",
          prefix, e.count, e.name, body));
    }
  }
  return absl::OkStatus();
}

// Field `index` (1-based, as proc(5) numbers them) of /proc/WHO/stat; empty
// when unreadable. Fields count from after the command, which may hold spaces
// but ends at the last ')'.
std::string ProcStatField(const std::string& who, int index) {
  std::ifstream stat("/proc/" + who + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');
  if (close == std::string::npos || close + 2 > text.size()) return "";
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  for (int i = 3; i <= index && fields >> field; ++i) {
    if (i == index) return field;
  }
  return "";
}

// Threads of this process (field 20, num_threads; 0 when unknown).
[[maybe_unused]] int ThreadCount() { return std::atoi(ProcStatField("self", 20).c_str()); }

// Whether a forked child may allocate. glibc's malloc is fork-safe, but
// AddressSanitizer's allocator (GCC 12's libasan) is not: a child forked while
// another thread holds its lock deadlocks in its first allocation (seen in
// the sanitizer build: a 2-frame mesh "did not finish within 5 s" in a
// multi-threaded worker). Under ASan a multi-threaded process therefore
// imports in-process; the single-threaded fuzzers and unit tests still fork.
bool ForkedImportIsSafe() { return !base::kAddressSanitizer || ThreadCount() == 1; }

// The state letter of a process (field 3: R running, S or D blocked; '?'
// when unreadable).
char ProcessState(pid_t pid) {
  const std::string state = ProcStatField(std::to_string(pid), 3);
  return state.empty() ? '?' : state[0];
}

void (*import_child_hook)(int) = nullptr;

// The import in a forked child (attempt 0 or 1: the testing hook's argument).
// `*blocked`: the child's time ran out while it was blocked, not running.
absl::StatusOr<ImportedCorners> ForkedImport(const std::filesystem::path& file, absl::string_view field,
                                             const std::string& prefix, int attempt, bool* blocked) {
  *blocked = false;
  std::error_code ec;
  const double file_size = static_cast<double>(std::filesystem::file_size(file, ec));
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    return absl::InternalError(absl::StrCat(prefix, ": cannot create a pipe: ", std::strerror(errno)));
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int error = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    return absl::ResourceExhaustedError(
        absl::StrCat(prefix, ": cannot start the mesh importer process: ", std::strerror(error)));
  }
  if (pid == 0) {
    // The child: a crash ends it with the signal (not the parent's handlers,
    // e.g. a sanitizer's or a fuzzer's), and it leaves by _exit, running no
    // atexit handlers or destructors of the parent's objects.
    // The child dies with its parent (a server killed mid-import leaves no
    // importer behind, e.g. one looping forever).
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(1);
    // Only our pipe stays open: an import running in another thread's child
    // must not hold this one's pipe open (its reader would wait for it).
    const int out = fds[1];
    if (out > 3) ::close_range(3, static_cast<unsigned>(out - 1), 0);
    ::close_range(static_cast<unsigned>(out + 1), ~0u, 0);
    // Default dispositions: neither the parent's shutdown handlers (mvbrdf
    // server and worker catch SIGINT and SIGTERM) nor a sanitizer's run here.
    for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL, SIGINT, SIGTERM, SIGHUP}) ::signal(sig, SIG_DFL);
    const struct rlimit no_core = {0, 0};  // no core dump for an importer crash
    ::setrlimit(RLIMIT_CORE, &no_core);
    // Address space: what the process has now plus kImportMemoryBytes and
    // kImportMemoryPerFileByte x the file size, so that a count a malformed
    // file declares (and the importer allocates for) fails in the child
    // rather than exhausting the machine's memory.
    if (std::FILE* statm = std::fopen("/proc/self/statm", "r")) {
      unsigned long long pages = 0;
      if (std::fscanf(statm, "%llu", &pages) == 1) {
        const double limit = static_cast<double>(pages) * static_cast<double>(::sysconf(_SC_PAGESIZE)) +
                             kImportMemoryBytes + kImportMemoryPerFileByte * static_cast<double>(file_size);
        const struct rlimit memory = {static_cast<rlim_t>(limit), static_cast<rlim_t>(limit)};
        ::setrlimit(RLIMIT_AS, &memory);
      }
      std::fclose(statm);
    }
    if (import_child_hook != nullptr) import_child_hook(attempt);
    const bool sent = WriteAllToFd(out, EncodeImport(ImportCornersHere(file, field)), "pipe").ok();
    ::_exit(sent ? 0 : 1);
  }
  ::close(fds[1]);
  const double limit_seconds = import_seconds + import_seconds_per_mib * file_size / (1 << 20);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(limit_seconds);
  std::string reply;
  char buffer[1 << 16];
  bool timed_out = false;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p = {fds[0], POLLIN, 0};
    const int ready = left.count() > 0 ? ::poll(&p, 1, static_cast<int>(left.count())) : 0;
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) {
      timed_out = true;
      break;
    }
    const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    reply.append(buffer, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  // What the child was doing when its time was up: R running, S or D blocked.
  const char state = timed_out ? ProcessState(pid) : '?';
  if (timed_out) ::kill(pid, SIGKILL);
  int wstatus = 0;
  pid_t waited;
  do {
    waited = ::waitpid(pid, &wstatus, 0);
  } while (waited < 0 && errno == EINTR);
  if (timed_out) {
    *blocked = state == 'S' || state == 'D';
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s: cannot read mesh: the importer (assimp) did not finish within %.0f s (it was %s)%s", prefix, limit_seconds,
        *blocked ? "blocked, not running" : "running", attempt > 0 ? ", twice" : ""));
  }
  if (waited == pid && WIFSIGNALED(wstatus)) {
    return absl::InvalidArgumentError(absl::StrCat(prefix, ": cannot read mesh: the importer (assimp) crashed on it (",
                                                   strsignal(WTERMSIG(wstatus)), ")"));
  }
  if (waited == pid && (!WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(prefix, ": cannot read mesh: the importer process failed (exit ", WEXITSTATUS(wstatus), ")"));
  }
  // waited != pid: SIGCHLD ignored, the child reaped itself; the framing says
  // whether it finished.
  return DecodeImport(reply, prefix);
}

absl::StatusOr<ImportedCorners> ImportCorners(const std::filesystem::path& file, absl::string_view field) {
  if (const std::string why = WhyNotRegularFile(file); !why.empty()) {
    return NotRegularFileError(
        why, absl::StrCat(field, ": mesh file ", why, ": ", ElideForMessage(file.string(), kMaxShownPathChars)));
  }
  const std::string prefix = Prefix(field, file);
  if (absl::AsciiStrToLower(file.extension().string()) == ".ply") {
    if (absl::Status counts = CheckPlyCounts(file, prefix); !counts.ok()) return counts;
  }
  if (!ForkedImportIsSafe()) return ImportCornersHere(file, field);
  // A child forked from a multi-threaded process can block for good on a
  // lock another thread held at the fork (it is copied held, its owner is not
  // copied). A child found blocked (not running, as an importer looping on a
  // malformed file is) when its time is up is therefore forked once more.
  // (Seen: in one CI run a service worker's import of a small synthetic OBJ
  // "did not finish within 5 s"; whether that child was blocked was not
  // recorded then. The message now says which.)
  bool blocked = false;
  absl::StatusOr<ImportedCorners> result = ForkedImport(file, field, prefix, 0, &blocked);
  if (blocked && ThreadCount() > 1) result = ForkedImport(file, field, prefix, 1, &blocked);
  return result;
}

// Distance of a UV outside [0,1]^2 along either axis (0 inside; NaN stays NaN).
float UvExcursion(const aiVector3D& uv) {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return std::numeric_limits<float>::quiet_NaN();
  return std::max({0.0f, -uv.x, uv.x - 1.0f, -uv.y, uv.y - 1.0f});
}

bool IsFinite(const aiVector3D& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string FormatVec(const aiVector3D& v) { return absl::StrFormat("(%g, %g, %g)", v.x, v.y, v.z); }

// Checks a later frame's corners against the rest-pose topology and returns
// one position per file vertex.
absl::StatusOr<FramePositions> PositionsFromCorners(const std::vector<Corner>& corners, const MeshTopology& topology,
                                                    const std::filesystem::path& file, absl::string_view field) {
  const size_t num_triangles = corners.size() / 3;
  if (num_triangles != topology.file_triangles.size()) {
    return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": topology differs from frame 0 (",
                                                   num_triangles, " triangles, expected ",
                                                   topology.file_triangles.size(), ")"));
  }
  FramePositions positions(topology.num_file_vertices);
  std::vector<uint8_t> seen(topology.num_file_vertices, 0);
  for (size_t c = 0; c < corners.size(); ++c) {
    const uint32_t v = topology.file_triangles[c / 3][static_cast<int>(c % 3)];
    const aiVector3D& p = corners[c].position;
    if (!seen[v]) {
      if (!IsFinite(p)) {
        return absl::InvalidArgumentError(
            absl::StrCat(Prefix(field, file), ": vertex ", v, " has a non-finite position ", FormatVec(p)));
      }
      positions[v] = glm::vec3(p.x, p.y, p.z);
      seen[v] = 1;
    } else if (Bits(p.x) != Bits(positions[v].x) || Bits(p.y) != Bits(positions[v].y) ||
               Bits(p.z) != Bits(positions[v].z)) {
      // The corners that share vertex v in frame 0 no longer coincide: the
      // file's connectivity is not frame 0's.
      return absl::InvalidArgumentError(absl::StrCat(
          Prefix(field, file), ": topology differs from frame 0 (triangle ", c / 3, " corner ", c % 3,
          " should be vertex ", v, " at ", FormatVec(aiVector3D(positions[v].x, positions[v].y, positions[v].z)),
          ", got ", FormatVec(p), ")"));
    }
  }
  return positions;
}

bool IsObj(const std::filesystem::path& file) { return absl::AsciiStrToLower(file.extension().string()) == ".obj"; }

// The corners of a plain OBJ file (obj_reader.h), read in this process;
// nullopt when it is not plain, too large (more than `max_corners` corners or
// vertices: a later frame has as many as the rest pose), or unreadable
// (assimp then reads it and reports what is wrong).
std::optional<std::vector<glm::vec3>> ReadPlainObjFile(const std::filesystem::path& file, size_t max_corners) {
  // The size first, so that a huge file is not read (a missing file, a
  // directory or a FIFO fails here or in ReadFileToString).
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(file, ec);
  if (ec || size > kMaxPlainObjBytes) return std::nullopt;
  absl::StatusOr<std::string> text = ReadFileToString(file);
  if (!text.ok()) return std::nullopt;
  return ReadPlainObjCorners(*text, max_corners);
}

bool SamePositions(const std::vector<glm::vec3>& plain, const std::vector<Corner>& corners) {
  if (plain.size() != corners.size()) return false;
  for (size_t c = 0; c < corners.size(); ++c) {
    const aiVector3D& p = corners[c].position;
    if (Bits(p.x) != Bits(plain[c].x) || Bits(p.y) != Bits(plain[c].y) || Bits(p.z) != Bits(plain[c].z)) return false;
  }
  return true;
}

// Corners (a, b, c) of each triangle become (a, c, b).
void FlipWinding(std::vector<Corner>& corners) {
  for (size_t c = 0; c + 2 < corners.size(); c += 3) std::swap(corners[c + 1], corners[c + 2]);
}

}  // namespace

MeshOrientation ComputeMeshOrientation(const MeshTopology& topology, const FramePositions& positions) {
  MeshOrientation out;
  if (positions.empty() || topology.file_triangles.empty()) return out;
  // Relative to the centroid, so that a mesh far from the origin loses no precision.
  glm::dvec3 centre(0.0), lo(positions[0]), hi(positions[0]);
  for (const glm::vec3& p : positions) {
    centre += glm::dvec3(p);
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  centre /= static_cast<double>(positions.size());
  const glm::dvec3 extent = hi - lo;
  out.diagonal_cubed = std::pow(glm::length(extent), 3.0);
  // Directed edge (from, to) -> uses; closed and consistent: each once, and its reverse once.
  std::unordered_map<uint64_t, int> edges;
  edges.reserve(topology.file_triangles.size() * 3);
  auto key = [](uint32_t a, uint32_t b) { return (static_cast<uint64_t>(a) << 32) | b; };
  for (const glm::uvec3& f : topology.file_triangles) {
    if (f.x >= positions.size() || f.y >= positions.size() || f.z >= positions.size()) return MeshOrientation{};
    const glm::dvec3 a = glm::dvec3(positions[f.x]) - centre, b = glm::dvec3(positions[f.y]) - centre,
                     c = glm::dvec3(positions[f.z]) - centre;
    out.signed_volume += glm::dot(a, glm::cross(b, c));
    ++edges[key(f.x, f.y)];
    ++edges[key(f.y, f.z)];
    ++edges[key(f.z, f.x)];
  }
  out.closed = true;
  for (const auto& [k, uses] : edges) {
    const auto reverse = edges.find((k << 32) | (k >> 32));
    if (uses != 1 || reverse == edges.end() || reverse->second != 1) {
      out.closed = false;
      break;
    }
  }
  return out;
}

void SetImportChildHookForTesting(void (*hook)(int attempt)) { import_child_hook = hook; }

absl::StatusOr<std::vector<glm::vec3>> ImportCornerPositionsHereForTesting(const std::filesystem::path& file) {
  absl::StatusOr<ImportedCorners> imported = ImportCornersHere(file, "file");
  if (!imported.ok()) return imported.status();
  std::vector<glm::vec3> out;
  out.reserve(imported->corners.size());
  for (const Corner& c : imported->corners) out.emplace_back(c.position.x, c.position.y, c.position.z);
  return out;
}

void SetImportTimeLimitForTesting(double seconds, double seconds_per_mib) {
  import_seconds = seconds;
  import_seconds_per_mib = seconds_per_mib;
}

absl::StatusOr<LoadedMesh> LoadMesh(const std::filesystem::path& file, absl::string_view field, bool flip_winding) {
  auto imported = ImportCorners(file, field);
  if (!imported.ok()) return imported.status();
  // Later frames are read in-process only when this file reads the same both ways.
  bool plain_obj = false;
  if (IsObj(file)) {
    // No bound: assimp's child has just read this file within its memory limit.
    const std::optional<std::vector<glm::vec3>> plain = ReadPlainObjFile(file, static_cast<size_t>(-1));
    plain_obj = plain.has_value() && SamePositions(*plain, imported->corners);
  }
  if (flip_winding) FlipWinding(imported->corners);
  const std::vector<Corner>& corners = imported->corners;
  const bool has_uvs = imported->has_uvs;

  LoadedMesh out;
  MeshTopology& topo = out.topology;
  const size_t num_triangles = corners.size() / 3;
  topo.triangles.resize(num_triangles);
  topo.file_triangles.resize(num_triangles);

  std::unordered_map<Key3, uint32_t, Key3Hash> file_vertex_of;
  // Render vertex key: file vertex and UV bits.
  std::unordered_map<Key3, uint32_t, Key3Hash> render_vertex_of;
  file_vertex_of.reserve(corners.size());
  render_vertex_of.reserve(corners.size());

  for (size_t c = 0; c < corners.size(); ++c) {
    const aiVector3D& p = corners[c].position;
    const auto [it, inserted] =
        file_vertex_of.try_emplace(Key3{Bits(p.x), Bits(p.y), Bits(p.z)}, static_cast<uint32_t>(out.positions.size()));
    if (inserted) {
      if (!IsFinite(p)) {
        return absl::InvalidArgumentError(absl::StrCat(Prefix(field, file), ": vertex ", out.positions.size(),
                                                       " (in order of first use by a face) has a non-finite position ",
                                                       FormatVec(p)));
      }
      out.positions.emplace_back(p.x, p.y, p.z);
    }
    const uint32_t fv = it->second;
    uint32_t rv = fv;
    if (has_uvs) {
      const aiVector3D& uv = corners[c].uv;
      const auto [rit, rinserted] = render_vertex_of.try_emplace(
          Key3{fv, Bits(uv.x), Bits(uv.y)}, static_cast<uint32_t>(topo.render_to_file_vertex.size()));
      if (rinserted) {
        const float excursion = UvExcursion(uv);
        if (!(excursion <= kMaxUvExcursion)) {
          return absl::InvalidArgumentError(absl::StrCat(
              Prefix(field, file), ": texture coordinate (", uv.x, ", ", uv.y, ") of vertex ", fv,
              " is outside [0,1]^2 by more than ", kMaxUvExcursion, " (tiled or unnormalised UVs are not supported)"));
        }
        if (excursion > kUvTolerance) topo.clamped_uv_vertices.push_back(static_cast<uint32_t>(topo.uvs.size()));
        topo.render_to_file_vertex.push_back(fv);
        topo.uvs.emplace_back(std::clamp(uv.x, 0.0f, 1.0f), std::clamp(uv.y, 0.0f, 1.0f));
      }
      rv = rit->second;
    }
    topo.file_triangles[c / 3][static_cast<int>(c % 3)] = fv;
    topo.triangles[c / 3][static_cast<int>(c % 3)] = rv;
  }
  topo.num_file_vertices = static_cast<uint32_t>(out.positions.size());
  topo.plain_obj = plain_obj;
  if (!has_uvs) {
    topo.render_to_file_vertex.resize(topo.num_file_vertices);
    for (uint32_t i = 0; i < topo.num_file_vertices; ++i) topo.render_to_file_vertex[i] = i;
  }

  // Zero-area triangles, relative to the mesh's size so units do not matter.
  glm::dvec3 lo(out.positions[0]), hi(out.positions[0]);
  for (const glm::vec3& p : out.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const double diagonal2 = glm::dot(hi - lo, hi - lo);
  for (size_t t = 0; t < num_triangles; ++t) {
    const glm::uvec3& f = topo.file_triangles[t];
    const glm::dvec3 a(out.positions[f.x]), b(out.positions[f.y]), c(out.positions[f.z]);
    const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
    if (!(area >= kZeroAreaRelative * diagonal2) || diagonal2 == 0.0) {
      topo.zero_area_triangles.push_back(static_cast<uint32_t>(t));
    }
  }
  return out;
}

absl::StatusOr<FramePositions> LoadFramePositions(const std::filesystem::path& file, const MeshTopology& topology,
                                                  absl::string_view field, bool flip_winding) {
  // In-process when the rest pose read the same that way and this file is
  // plain too (~3 ms for bench-e2e's 12 k-vertex frame against 45-120 ms for
  // assimp in its child); otherwise through assimp like the rest pose. Either
  // way the same text gives the same floats bit for bit.
  if (topology.plain_obj && IsObj(file)) {
    if (std::optional<std::vector<glm::vec3>> plain = ReadPlainObjFile(file, 3 * topology.file_triangles.size())) {
      std::vector<Corner> corners(plain->size());
      for (size_t c = 0; c < corners.size(); ++c) corners[c].position = aiVector3D((*plain)[c].x, (*plain)[c].y, (*plain)[c].z);
      if (flip_winding) FlipWinding(corners);
      return PositionsFromCorners(corners, topology, file, field);
    }
  }
  auto imported = ImportCorners(file, field);
  if (!imported.ok()) return imported.status();
  if (flip_winding) FlipWinding(imported->corners);
  return PositionsFromCorners(imported->corners, topology, file, field);
}

absl::Status WriteObj(const std::filesystem::path& file, const MeshTopology& topology,
                      const FramePositions& positions) {
  if (positions.size() != topology.num_file_vertices) {
    return absl::InvalidArgumentError(absl::StrCat(file.string(), ": ", positions.size(), " positions for a mesh with ",
                                                   topology.num_file_vertices, " file vertices"));
  }
  std::string out;
  out.reserve(positions.size() * 40 + topology.triangles.size() * 30);
  out += "# written by mvbrdf\n";
  char line[128];
  for (const glm::vec3& p : positions) {
    // %.9g round-trips a float exactly.
    std::snprintf(line, sizeof(line), "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
    out += line;
  }
  const bool uvs = topology.has_uvs();
  if (uvs) {
    for (const glm::vec2& uv : topology.uvs) {
      std::snprintf(line, sizeof(line), "vt %.9g %.9g\n", uv.x, uv.y);
      out += line;
    }
  }
  for (size_t t = 0; t < topology.file_triangles.size(); ++t) {
    const glm::uvec3& f = topology.file_triangles[t];
    if (uvs) {
      const glm::uvec3& r = topology.triangles[t];
      std::snprintf(line, sizeof(line), "f %u/%u %u/%u %u/%u\n", f.x + 1, r.x + 1, f.y + 1, r.y + 1, f.z + 1, r.z + 1);
    } else {
      std::snprintf(line, sizeof(line), "f %u %u %u\n", f.x + 1, f.y + 1, f.z + 1);
    }
    out += line;
  }
  return WriteStringToFile(file, out);
}

}  // namespace mvbrdf::scene
