#include "core/samples/sample_set.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/samples/half_float.h"

namespace mvbrdf::samples {
namespace {

// Programmer invariants (a caller passing an out-of-range frame or camera
// index): abort with a message, as core/resample does.
void Check(bool condition, const char* message) {
  if (condition) return;
  std::fprintf(stderr, "core/samples/sample_set.cc: %s\n", message);
  std::abort();
}

// ---------------------------------------------------------------------------
// Encoding, version 1. All integers and floats little-endian.
//
//   offset  size            field
//   0       4               magic "MVSS"
//   4       4   u32         version (1)
//   8       4   u32         flags: bit 0 = compact (halves), bit 1 = falloff
//                           array present; other bits must be 0
//   12      4   u32         L = number of lights (0..kMaxLights)
//   16      8   u64         N = number of samples
//   24      ...             L times: u32 name length, name bytes (UTF-8, no
//                           terminator, at most kMaxNameBytes), 3 x f32 intensity
//           then the arrays, each N (or N*3, N*L) long, in this order:
//                           element u32, frame u16, camera u8,
//                           reflectance 3 x (f16 | f32), g L x (f16 | f32),
//                           h L x (f16 | f32), [falloff L x (f16 | f32)]
//   The buffer ends exactly after the last array; trailing bytes are an error.
// ---------------------------------------------------------------------------
constexpr char kMagic[4] = {'M', 'V', 'S', 'S'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kFlagCompact = 1u;
constexpr uint32_t kFlagFalloff = 2u;
constexpr uint32_t kKnownFlags = kFlagCompact | kFlagFalloff;
constexpr uint32_t kMaxNameBytes = 4096;
constexpr size_t kHeaderBytes = 24;

class Writer {
 public:
  explicit Writer(std::string* out) : out_(out) {}
  void Bytes(const void* data, size_t n) { out_->append(static_cast<const char*>(data), n); }
  void U8(uint8_t v) { out_->push_back(static_cast<char>(v)); }
  void U16(uint16_t v) {
    U8(static_cast<uint8_t>(v));
    U8(static_cast<uint8_t>(v >> 8));
  }
  void U32(uint32_t v) {
    U16(static_cast<uint16_t>(v));
    U16(static_cast<uint16_t>(v >> 16));
  }
  void U64(uint64_t v) {
    U32(static_cast<uint32_t>(v));
    U32(static_cast<uint32_t>(v >> 32));
  }
  void F32(float v) {
    uint32_t bits;
    std::memcpy(&bits, &v, 4);
    U32(bits);
  }
  void Real(float v, bool compact) {
    if (compact) {
      U16(FloatToHalf(v));
    } else {
      F32(v);
    }
  }

 private:
  std::string* out_;
};

// Bounds-checked reader: every accessor first checks the remaining bytes, so a
// truncated buffer fails instead of reading past the end.
class Reader {
 public:
  explicit Reader(absl::string_view bytes) : data_(bytes) {}
  size_t remaining() const { return data_.size() - pos_; }
  size_t position() const { return pos_; }
  bool Has(size_t n) const { return n <= remaining(); }
  // The caller has checked Has().
  uint8_t U8() { return static_cast<uint8_t>(data_[pos_++]); }
  uint16_t U16() {
    const uint16_t lo = U8();
    return static_cast<uint16_t>(lo | (static_cast<uint16_t>(U8()) << 8));
  }
  uint32_t U32() {
    const uint32_t lo = U16();
    return lo | (static_cast<uint32_t>(U16()) << 16);
  }
  uint64_t U64() {
    const uint64_t lo = U32();
    return lo | (static_cast<uint64_t>(U32()) << 32);
  }
  float F32() {
    const uint32_t bits = U32();
    float v;
    std::memcpy(&v, &bits, 4);
    return v;
  }
  float Real(bool compact) { return compact ? HalfToFloat(U16()) : F32(); }
  absl::string_view Take(size_t n) {
    absl::string_view s = data_.substr(pos_, n);
    pos_ += n;
    return s;
  }

 private:
  absl::string_view data_;
  size_t pos_ = 0;
};

absl::Status Truncated(const char* what, size_t offset, size_t need, size_t have) {
  return absl::DataLossError(absl::StrCat("sample set encoding: truncated ", what, " at byte ", offset, ": need ",
                                          need, " bytes, ", have, " left"));
}

}  // namespace

void SampleSet::Add(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, const float* g_row,
                    const float* h_row, const float* falloff_row) {
  Check(frame_index >= 0 && frame_index <= std::numeric_limits<uint16_t>::max(),
        "SampleSet::Add: frame index out of the uint16 range");
  Check(camera_index >= 0 && camera_index <= std::numeric_limits<uint8_t>::max(),
        "SampleSet::Add: camera index out of the uint8 range");
  Check(light_intensity.size() == light_names.size(), "SampleSet::Add: light_intensity and light_names differ in size");
  const int num = num_lights();
  Check(num == 0 || (g_row != nullptr && h_row != nullptr), "SampleSet::Add: null g or h row");
  element.push_back(element_id);
  frame.push_back(static_cast<uint16_t>(frame_index));
  camera.push_back(static_cast<uint8_t>(camera_index));
  reflectance.push_back(rgb);
  if (num > 0) {
    g.insert(g.end(), g_row, g_row + num);
    h.insert(h.end(), h_row, h_row + num);
  }
  if (falloff_row != nullptr) {
    // The first row with fall-off: the samples before it had a_k = 1.
    if (falloff.empty()) falloff.assign((size() - 1) * static_cast<size_t>(num), 1.0f);
    falloff.insert(falloff.end(), falloff_row, falloff_row + num);
  } else if (!falloff.empty()) {
    falloff.insert(falloff.end(), static_cast<size_t>(num), 1.0f);
  }
}

absl::StatusOr<LightMask> SampleSet::MaskOf(const std::vector<std::string>& names) const {
  LightMask mask = 0;
  for (const std::string& name : names) {
    bool found = false;
    for (int k = 0; k < num_lights() && k < kMaxLights; ++k) {
      if (light_names[k] == name) {
        mask |= LightMask{1} << k;
        found = true;
        break;
      }
    }
    if (!found) {
      std::string known;
      for (const std::string& n : light_names) absl::StrAppend(&known, known.empty() ? "" : ", ", n);
      return absl::InvalidArgumentError(
          absl::StrCat("light configuration: unknown light \"", name, "\" (the sample set has: ", known, ")"));
    }
  }
  return mask;
}

glm::vec3 SampleSet::Illumination(size_t i, LightMask mask) const {
  const int num = num_lights();
  const float* g_row = g.data() + i * static_cast<size_t>(num);
  glm::vec3 sum(0.0f);
  for (int k = 0; k < num && k < kMaxLights; ++k) {
    if (mask & (LightMask{1} << k)) sum += light_intensity[k] * g_row[k];
  }
  return sum;
}

size_t SampleSet::MemoryBytes() const {
  size_t bytes = sizeof(SampleSet);
  for (const std::string& name : light_names) bytes += sizeof(std::string) + name.capacity();
  bytes += light_intensity.capacity() * sizeof(glm::vec3);
  bytes += element.capacity() * sizeof(uint32_t);
  bytes += frame.capacity() * sizeof(uint16_t);
  bytes += camera.capacity() * sizeof(uint8_t);
  bytes += reflectance.capacity() * sizeof(glm::vec3);
  bytes += g.capacity() * sizeof(float);
  bytes += h.capacity() * sizeof(float);
  bytes += falloff.capacity() * sizeof(float);
  return bytes;
}

std::string EncodeSampleSet(const SampleSet& set, bool compact) {
  const size_t n = set.size();
  const size_t num = static_cast<size_t>(set.num_lights());
  Check(num <= static_cast<size_t>(kMaxLights), "EncodeSampleSet: more than kMaxLights lights");
  Check(set.light_intensity.size() == num, "EncodeSampleSet: light_intensity and light_names differ in size");
  const bool has_falloff = !set.falloff.empty();
  Check(set.frame.size() == n && set.camera.size() == n && set.reflectance.size() == n && set.g.size() == n * num &&
            set.h.size() == n * num && (!has_falloff || set.falloff.size() == n * num),
        "EncodeSampleSet: arrays of inconsistent sizes");
  const size_t real = compact ? 2 : 4;
  std::string out;
  size_t names = 0;
  for (const std::string& name : set.light_names) {
    Check(name.size() <= kMaxNameBytes, "EncodeSampleSet: light name longer than 4096 bytes");
    names += 4 + name.size() + 12;
  }
  const size_t arrays = has_falloff ? 3 : 2;
  out.reserve(kHeaderBytes + names + n * (4 + 2 + 1 + real * (3 + arrays * num)));
  Writer w(&out);
  w.Bytes(kMagic, 4);
  w.U32(kVersion);
  w.U32((compact ? kFlagCompact : 0u) | (has_falloff ? kFlagFalloff : 0u));
  w.U32(static_cast<uint32_t>(num));
  w.U64(n);
  for (size_t k = 0; k < num; ++k) {
    w.U32(static_cast<uint32_t>(set.light_names[k].size()));
    w.Bytes(set.light_names[k].data(), set.light_names[k].size());
    for (int c = 0; c < 3; ++c) w.F32(set.light_intensity[k][c]);
  }
  for (uint32_t e : set.element) w.U32(e);
  for (uint16_t f : set.frame) w.U16(f);
  for (uint8_t c : set.camera) w.U8(c);
  for (const glm::vec3& rgb : set.reflectance) {
    for (int c = 0; c < 3; ++c) w.Real(rgb[c], compact);
  }
  for (float v : set.g) w.Real(v, compact);
  for (float v : set.h) w.Real(v, compact);
  for (float v : set.falloff) w.Real(v, compact);
  return out;
}

absl::StatusOr<SampleSet> DecodeSampleSet(absl::string_view bytes) {
  Reader r(bytes);
  if (!r.Has(4)) return Truncated("magic", 0, 4, r.remaining());
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) {
    return absl::DataLossError("sample set encoding: bad magic (expected \"MVSS\"): not a sample set");
  }
  r.Take(4);
  if (!r.Has(kHeaderBytes - 4)) return Truncated("header", r.position(), kHeaderBytes - 4, r.remaining());
  const uint32_t version = r.U32();
  if (version != kVersion) {
    return absl::DataLossError(
        absl::StrCat("sample set encoding: unknown version ", version, " (this build reads version ", kVersion, ")"));
  }
  const uint32_t flags = r.U32();
  if (flags & ~kKnownFlags) {
    return absl::DataLossError(absl::StrCat("sample set encoding: unknown flags 0x", absl::Hex(flags)));
  }
  const bool compact = (flags & kFlagCompact) != 0;
  const bool has_falloff = (flags & kFlagFalloff) != 0;
  const uint32_t num_lights = r.U32();
  if (num_lights > static_cast<uint32_t>(kMaxLights)) {
    return absl::DataLossError(
        absl::StrCat("sample set encoding: light count ", num_lights, " exceeds the maximum ", kMaxLights));
  }
  const uint64_t num_samples = r.U64();

  SampleSet set;
  set.light_names.reserve(num_lights);
  set.light_intensity.reserve(num_lights);
  for (uint32_t k = 0; k < num_lights; ++k) {
    if (!r.Has(4)) return Truncated("light name length", r.position(), 4, r.remaining());
    const uint32_t length = r.U32();
    if (length > kMaxNameBytes) {
      return absl::DataLossError(absl::StrCat("sample set encoding: light ", k, " name length ", length,
                                              " exceeds the maximum ", kMaxNameBytes));
    }
    if (!r.Has(length + size_t{12})) return Truncated("light", r.position(), length + size_t{12}, r.remaining());
    set.light_names.emplace_back(r.Take(length));
    glm::vec3 intensity;
    for (int c = 0; c < 3; ++c) intensity[c] = r.F32();
    set.light_intensity.push_back(intensity);
  }

  // The arrays must fill the rest of the buffer exactly. Check the count
  // against the remaining bytes before allocating anything from it.
  const size_t real = compact ? 2 : 4;
  const size_t per_sample = 4 + 2 + 1 + real * (3 + (has_falloff ? 3 : 2) * size_t{num_lights});
  const size_t left = r.remaining();
  if (num_samples > left / per_sample) {
    return absl::DataLossError(absl::StrCat("sample set encoding: truncated arrays: sample count ", num_samples,
                                            " needs ", per_sample, " bytes per sample, ", left, " bytes left"));
  }
  const size_t n = static_cast<size_t>(num_samples);
  if (left != n * per_sample) {
    return absl::DataLossError(absl::StrCat("sample set encoding: counts inconsistent with the buffer: ", n,
                                            " samples x ", per_sample, " bytes = ", n * per_sample, ", but ", left,
                                            " bytes follow the header"));
  }
  const size_t num = num_lights;
  // EncodeSampleSet sets the flag only for a non-empty falloff array, so one
  // set has one encoding (found by tests/fuzz/sample_set_fuzz: the flag with
  // no samples or no lights decoded, and re-encoded without it).
  if (has_falloff && n * num == 0) {
    return absl::DataLossError(absl::StrCat("sample set encoding: falloff flag set but there are no falloff values (",
                                            n, " samples x ", num, " lights)"));
  }
  set.element.resize(n);
  set.frame.resize(n);
  set.camera.resize(n);
  set.reflectance.resize(n);
  set.g.resize(n * num);
  set.h.resize(n * num);
  if (has_falloff) set.falloff.resize(n * num);
  for (size_t i = 0; i < n; ++i) set.element[i] = r.U32();
  for (size_t i = 0; i < n; ++i) set.frame[i] = r.U16();
  for (size_t i = 0; i < n; ++i) set.camera[i] = r.U8();
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) set.reflectance[i][c] = r.Real(compact);
  }
  for (float& v : set.g) v = r.Real(compact);
  for (float& v : set.h) v = r.Real(compact);
  for (float& v : set.falloff) v = r.Real(compact);
  return set;
}

}  // namespace mvbrdf::samples
