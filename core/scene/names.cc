#include "core/scene/names.h"

#include <algorithm>
#include <cstdint>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace mvbrdf::scene {
namespace {

// The length of the UTF-8 sequence starting at text[i] (1-4), or 0 when it
// is not a valid one (overlong forms, surrogates and code points above
// U+10FFFF are invalid). `*code_point` receives the decoded value.
size_t Utf8SequenceAt(absl::string_view text, size_t i, uint32_t* code_point) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
  const uint8_t b0 = byte(i);
  size_t n = 0;
  uint32_t cp = 0, min = 0;
  if (b0 < 0x80) {
    *code_point = b0;
    return 1;
  } else if ((b0 & 0xE0) == 0xC0) {
    n = 2, cp = b0 & 0x1F, min = 0x80;
  } else if ((b0 & 0xF0) == 0xE0) {
    n = 3, cp = b0 & 0x0F, min = 0x800;
  } else if ((b0 & 0xF8) == 0xF0) {
    n = 4, cp = b0 & 0x07, min = 0x10000;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (byte(i + k) & 0x3F);
  }
  if (cp < min || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return 0;
  *code_point = cp;
  return n;
}

}  // namespace

absl::Status ValidateName(absl::string_view field, absl::string_view name) {
  const auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", why, ", got \"", absl::CHexEscape(name), "\""));
  };
  if (name.empty()) return absl::InvalidArgumentError(absl::StrCat(field, ": must not be empty"));
  if (name.size() > kMaxNameBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": must be at most ", kMaxNameBytes, " bytes, got ", name.size(), " bytes"));
  }
  if (name == "." || name == "..") return bad("must not be \".\" or \"..\" (names become file names)");
  for (size_t i = 0; i < name.size();) {
    uint32_t cp = 0;
    const size_t n = Utf8SequenceAt(name, i, &cp);
    if (n == 0) return bad("must be valid UTF-8");
    if (cp == '/' || cp == '\\') return bad("must not contain '/' or '\\' (names become file names)");
    if (cp < 0x20 || (cp >= 0x7F && cp < 0xA0))
      return bad("must not contain control characters (NUL, newline, tab, ESC...)");
    i += n;
  }
  return absl::OkStatus();
}

absl::StatusOr<std::filesystem::path> FileNameFor(const std::filesystem::path& dir, absl::string_view name,
                                                  absl::string_view suffix) {
  if (absl::Status s = ValidateName("name", name); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), ": refusing to write a file named after \"",
                                                   absl::CHexEscape(name), "\": ", s.message()));
  }
  const std::filesystem::path file_name(absl::StrCat(name, suffix));
  if (file_name.has_parent_path() || file_name.has_root_path() || file_name == "." || file_name == "..") {
    return absl::InvalidArgumentError(absl::StrCat(dir.string(), ": refusing the file name \"",
                                                   absl::CHexEscape(file_name.string()), "\" (not a plain file name)"));
  }
  return dir / file_name;
}

std::string ShownName(absl::string_view name) {
  std::string shown;
  for (size_t i = 0; i < name.size();) {
    uint32_t cp = 0;
    const size_t n = Utf8SequenceAt(name, i, &cp);
    if (n == 0 || cp < 0x20 || (cp >= 0x7F && cp < 0xA0)) {
      const size_t bytes = n == 0 ? 1 : n;
      for (size_t k = 0; k < bytes; ++k) {
        absl::StrAppend(&shown, "\\x", absl::Hex(static_cast<uint8_t>(name[i + k]), absl::kZeroPad2));
      }
      i += bytes;
    } else {
      shown.append(name.data() + i, n);
      i += n;
    }
  }
  return shown;
}

std::string ShownText(absl::string_view text) {
  std::string shown;
  bool first = true;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    absl::StrAppend(&shown, first ? "" : "\n", ShownName(line));
    first = false;
  }
  return shown;
}

std::string NameList(const std::vector<std::string>& names, size_t max_shown) {
  if (names.empty()) return "none";
  std::string out;
  const size_t shown = names.size() > max_shown ? max_shown : names.size();
  for (size_t i = 0; i < shown; ++i) absl::StrAppend(&out, i == 0 ? "" : ", ", "\"", ShownName(names[i]), "\"");
  if (shown < names.size()) absl::StrAppend(&out, ", \u2026 (", names.size(), " in all)");
  return out;
}

std::string ClosestName(absl::string_view name, const std::vector<std::string>& candidates) {
  const std::string a = absl::AsciiStrToLower(name);
  std::string best;
  size_t best_distance = SIZE_MAX;
  for (const std::string& candidate : candidates) {
    const std::string b = absl::AsciiStrToLower(candidate);
    // Levenshtein distance, one row.
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
      size_t diagonal = row[0];
      row[0] = i;
      for (size_t j = 1; j <= b.size(); ++j) {
        const size_t up = row[j];
        row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
        diagonal = up;
      }
    }
    if (row[b.size()] < best_distance) {
      best_distance = row[b.size()];
      best = candidate;
    }
  }
  const size_t allowed = std::max<size_t>(2, a.size() / 3);
  if (best.empty() || best_distance > allowed || best_distance >= a.size() || best == name) return "";
  return best;
}

}  // namespace mvbrdf::scene
