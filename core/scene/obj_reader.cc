#include "core/scene/obj_reader.h"

#include <assimp/fast_atof.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <exception>

namespace mvbrdf::scene {
namespace {

constexpr size_t kMaxToken = 64;
constexpr size_t kMaxIndexDigits = 9;  // below 2^31: assimp reads indices with atoi

bool IsBlank(char c) { return c == ' ' || c == '\t'; }
bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// The line's words, split at blanks; false when there are more than N or one
// is longer than kMaxToken.
template <size_t N>
bool SplitWords(std::string_view line, std::array<std::string_view, N>* words, size_t* count) {
  *count = 0;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && IsBlank(line[i])) ++i;
    if (i == line.size()) break;
    const size_t start = i;
    while (i < line.size() && !IsBlank(line[i])) ++i;
    if (*count == N || i - start > kMaxToken) return false;
    (*words)[(*count)++] = line.substr(start, i - start);
  }
  return true;
}

size_t SkipDigits(std::string_view s, size_t i) {
  while (i < s.size() && IsDigit(s[i])) ++i;
  return i;
}

// [+-]?[0-9]+(\.[0-9]+)?([eE][+-]?[0-9]+)?: what assimp counts as a number
// (it starts with a digit or a sign) and reads whole.
bool IsPlainNumber(std::string_view s) {
  size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  size_t j = SkipDigits(s, i);
  if (j == i) return false;
  i = j;
  if (i < s.size() && s[i] == '.') {
    j = SkipDigits(s, i + 1);
    if (j == i + 1) return false;
    i = j;
  }
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    j = SkipDigits(s, i);
    if (j == i) return false;
    i = j;
  }
  return i == s.size();
}

// What assimp's number parser throws for a number it refuses (its own
// DeadlyImportError is not exported by Debian's libassimp).
struct RefusedNumber : std::exception {
  template <typename... Args>
  explicit RefusedNumber(Args&&...) {}
};

// A number as assimp's OBJ importer reads it (ObjFileParser: fast_atof of
// the word). Throws RefusedNumber where assimp would fail the file.
float ParseNumber(std::string_view word) {
  char buffer[kMaxToken + 1];
  std::memcpy(buffer, word.data(), word.size());
  buffer[word.size()] = '\0';
  return static_cast<float>(Assimp::fast_atof<RefusedNumber>(buffer));
}

// A 1-based index of at most kMaxIndexDigits digits; 0 when malformed. No
// leading zero: assimp steps over as many bytes as the value has digits, so
// "04" would read as 4 and then 4 again.
uint32_t ParseIndex(std::string_view s) {
  if (s.empty() || s.size() > kMaxIndexDigits || s[0] == '0') return 0;
  uint32_t v = 0;
  for (char c : s) {
    if (!IsDigit(c)) return 0;
    v = v * 10 + static_cast<uint32_t>(c - '0');
  }
  return v;
}

struct FaceCorner {
  uint32_t position = 0;
  uint32_t uv = 0;      // 0: none
  uint32_t normal = 0;  // 0: none
};

// P, P/T, P/T/N or P//N.
bool ParseCorner(std::string_view word, FaceCorner* corner) {
  const size_t a = word.find('/');
  corner->position = ParseIndex(word.substr(0, a));
  if (corner->position == 0) return false;
  if (a == std::string_view::npos) return true;
  const std::string_view rest = word.substr(a + 1);
  const size_t b = rest.find('/');
  if (b == std::string_view::npos) return (corner->uv = ParseIndex(rest)) != 0;
  if (b != 0 && (corner->uv = ParseIndex(rest.substr(0, b))) == 0) return false;
  return (corner->normal = ParseIndex(rest.substr(b + 1))) != 0;
}

bool ReadNumbers(std::string_view line, size_t min, size_t max, std::array<float, 3>* out) {
  std::array<std::string_view, 3> words;
  size_t count = 0;
  if (!SplitWords(line, &words, &count) || count < min || count > max) return false;
  for (size_t k = 0; k < count; ++k) {
    if (!IsPlainNumber(words[k])) return false;
    if (out != nullptr) (*out)[k] = ParseNumber(words[k]);
  }
  return true;
}

// The keyword of a line ("v", "f", "usemtl", ...) and what follows it.
std::string_view Keyword(std::string_view line, std::string_view* rest) {
  size_t i = 0;
  while (i < line.size() && !IsBlank(line[i])) ++i;
  *rest = line.substr(i);
  return line.substr(0, i);
}

std::optional<std::vector<glm::vec3>> Read(std::string_view text, size_t max_corners) {
  if (text.size() > kMaxPlainObjBytes || text.find('\0') != std::string_view::npos ||
      text.find('\\') != std::string_view::npos) {
    return std::nullopt;
  }
  std::vector<glm::vec3> positions;
  std::vector<FaceCorner> corners;
  size_t num_uvs = 0, num_normals = 0;
  size_t begin = 0;
  while (begin < text.size()) {
    size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(begin, end - begin);
    begin = end + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    // Assimp ends lines at \r and \f too, and keys a line on its first byte.
    if (line.find_first_of("\r\f\v") != std::string_view::npos) return std::nullopt;
    if (line.empty()) continue;
    if (IsBlank(line[0])) {
      if (line.find_first_not_of(" \t") != std::string_view::npos) return std::nullopt;
      continue;
    }
    if (line[0] == '#') continue;
    std::string_view rest;
    const std::string_view key = Keyword(line, &rest);
    if (rest.find('#') != std::string_view::npos) return std::nullopt;
    if (key == "v") {
      std::array<float, 3> p{};
      if (!ReadNumbers(rest, 3, 3, &p) || positions.size() == max_corners) return std::nullopt;
      positions.emplace_back(p[0], p[1], p[2]);
    } else if (key == "vt") {
      if (!ReadNumbers(rest, 2, 3, nullptr)) return std::nullopt;
      ++num_uvs;
    } else if (key == "vn") {
      if (!ReadNumbers(rest, 3, 3, nullptr)) return std::nullopt;
      ++num_normals;
    } else if (key == "f") {
      std::array<std::string_view, 3> words;
      size_t count = 0;
      if (!SplitWords(rest, &words, &count) || count != 3 || corners.size() + 3 > max_corners) return std::nullopt;
      for (const std::string_view word : words) {
        FaceCorner corner;
        if (!ParseCorner(word, &corner)) return std::nullopt;
        corners.push_back(corner);
      }
    } else if (key == "s" || key == "mtllib") {
      continue;
    } else if (key == "o" || key == "g" || key == "usemtl") {
      if (!corners.empty()) return std::nullopt;
    } else {
      return std::nullopt;
    }
  }
  if (corners.empty()) return std::nullopt;
  std::vector<glm::vec3> out;
  out.reserve(corners.size());
  for (const FaceCorner& c : corners) {
    if (c.position > positions.size() || c.uv > num_uvs || c.normal > num_normals) return std::nullopt;
    out.push_back(positions[c.position - 1]);
  }
  return out;
}

}  // namespace

std::optional<std::vector<glm::vec3>> ReadPlainObjCorners(std::string_view text, size_t max_corners) {
  try {
    return Read(text, max_corners);
  } catch (const RefusedNumber&) {
    // Assimp's number parser refused a number: so would its importer.
    return std::nullopt;
  }
}

}  // namespace mvbrdf::scene
