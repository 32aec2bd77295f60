#include "core/samples/sample_set.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
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
// Encoding, version 3. All integers and floats little-endian.
//
//   offset  size            field
//   0       4               magic "MVSS"
//   4       4   u32         version (3; 2 is read too: no bit 2)
//   8       4   u32         flags: bit 0 = compact (halves), bit 1 = falloff
//                           array present, bit 2 = half-vector geometry
//                           present (version 3); other bits must be 0
//   12      4   u32         L = number of lights (0..kMaxLights)
//   16      8   u64         N = number of samples
//   24      8   u64         T = number of terms (sum of the counts)
//   32      ...             L times: u32 name length, name bytes (UTF-8, no
//                           terminator, at most kMaxNameBytes), 3 x f32 intensity
//           then the arrays, each N (or N*3, T) long, in this order:
//                           element u32, frame u16, camera u8,
//                           reflectance 3 x (f16 | f32), count u16 (terms of
//                           the sample, <= L), light u16 (< L, ascending
//                           within a sample), g (f16 | f32), h (f16 | f32),
//                           [falloff (f16 | f32)],
//                           [n.v (N), n.h (T), v.h (T) (f16 | f32)]
//   The buffer ends exactly after the last array; trailing bytes are an error.
// Version 1 (dense N x L rows, L <= 16) is refused: DATA_LOSS.
// ---------------------------------------------------------------------------
constexpr char kMagic[4] = {'M', 'V', 'S', 'S'};
constexpr uint32_t kVersion = 3;
constexpr uint32_t kFlagCompact = 1u;
constexpr uint32_t kFlagFalloff = 2u;
constexpr uint32_t kFlagHalfVector = 4u;  // version 3
constexpr uint32_t kKnownFlags = kFlagCompact | kFlagFalloff | kFlagHalfVector;
constexpr uint32_t kMaxNameBytes = 4096;
constexpr size_t kHeaderBytes = 32;

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

LightMask LightMask::FirstN(size_t n) {
  LightMask m;
  m.low_ = n >= 64 ? ~uint64_t{0} : (uint64_t{1} << n) - 1u;
  if (n > 64) {
    m.high_.assign((n - 1) / 64, ~uint64_t{0});
    if (n % 64 != 0) m.high_.back() = (uint64_t{1} << (n % 64)) - 1u;
  }
  return m;
}

void LightMask::Set(size_t k) {
  if (k < 64) {
    low_ |= uint64_t{1} << k;
    return;
  }
  const size_t w = k / 64 - 1;
  if (w >= high_.size()) high_.resize(w + 1, 0u);
  high_[w] |= uint64_t{1} << (k % 64);
}

size_t LightMask::Count() const {
  size_t n = static_cast<size_t>(__builtin_popcountll(low_));
  for (uint64_t w : high_) n += static_cast<size_t>(__builtin_popcountll(w));
  return n;
}

size_t LightMask::End() const {
  for (size_t w = NumWords(); w-- > 0;) {
    const uint64_t bits = Word(w);
    if (bits != 0) return 64 * w + 64 - static_cast<size_t>(__builtin_clzll(bits));
  }
  return 0;
}

LightMask& LightMask::operator|=(const LightMask& other) {
  low_ |= other.low_;
  if (high_.size() < other.high_.size()) high_.resize(other.high_.size(), 0u);
  for (size_t w = 0; w < other.high_.size(); ++w) high_[w] |= other.high_[w];
  return *this;
}

LightMask& LightMask::operator&=(const LightMask& other) {
  low_ &= other.low_;
  if (high_.size() > other.high_.size()) high_.resize(other.high_.size());
  for (size_t w = 0; w < high_.size(); ++w) high_[w] &= other.high_[w];
  Trim();
  return *this;
}

LightMask LightMask::Without(const LightMask& other) const {
  LightMask m = *this;
  m.low_ &= ~other.low_;
  for (size_t w = 0; w < m.high_.size() && w < other.high_.size(); ++w) m.high_[w] &= ~other.high_[w];
  m.Trim();
  return m;
}

void LightMask::Trim() {
  while (!high_.empty() && high_.back() == 0) high_.pop_back();
}

std::string LightMask::ToString() const {
  std::string out = "0x";
  bool leading = true;
  for (size_t w = NumWords(); w-- > 0;) {
    const uint64_t bits = Word(w);
    if (leading) {
      if (bits == 0 && w > 0) continue;
      absl::StrAppend(&out, absl::Hex(bits));
      leading = false;
    } else {
      absl::StrAppend(&out, absl::Hex(bits, absl::kZeroPad16));
    }
  }
  return out;
}

namespace {

// A term is kept unless its g is a finite value <= 0, which adds nothing to
// any model term (h is 0 where g is, SampleSet's contract).
inline bool KeepTerm(float g) { return g > 0.0f || !std::isfinite(g); }

}  // namespace

void SampleSet::Add(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, const float* g_row,
                    const float* h_row, const float* falloff_row) {
  const int num = num_lights();
  Check(num == 0 || (g_row != nullptr && h_row != nullptr), "SampleSet::Add: null g or h row");
  Check(!half_vector, "SampleSet::Add: dense rows carry no half-vector geometry (use AddTerms)");
  uint16_t lights[kMaxLights];
  float gs[kMaxLights], hs[kMaxLights], as[kMaxLights];
  Check(num <= kMaxLights, "SampleSet::Add: more than kMaxLights lights");
  size_t count = 0;
  for (int k = 0; k < num; ++k) {
    if (!KeepTerm(g_row[k])) continue;
    lights[count] = static_cast<uint16_t>(k);
    gs[count] = g_row[k];
    hs[count] = h_row[k];
    as[count] = falloff_row != nullptr ? falloff_row[k] : 1.0f;
    ++count;
  }
  AddTerms(element_id, frame_index, camera_index, rgb, count, lights, gs, hs, falloff_row != nullptr ? as : nullptr);
}

void SampleSet::AddTerms(uint32_t element_id, int frame_index, int camera_index, const glm::vec3& rgb, size_t count,
                         const uint16_t* lights, const float* g_terms, const float* h_terms,
                         const float* falloff_terms, const HalfVectorTerms& geometry) {
  Check(frame_index >= 0 && frame_index <= std::numeric_limits<uint16_t>::max(),
        "SampleSet::Add: frame index out of the uint16 range");
  Check(camera_index >= 0 && camera_index <= std::numeric_limits<uint8_t>::max(),
        "SampleSet::Add: camera index out of the uint8 range");
  Check(light_intensity.size() == light_names.size(), "SampleSet::Add: light_intensity and light_names differ in size");
  Check(offset.size() == size() + 1 && offset.back() == light.size(), "SampleSet::Add: offset does not match");
  Check(count == 0 || (lights != nullptr && g_terms != nullptr && h_terms != nullptr),
        "SampleSet::AddTerms: null terms");
  Check(!half_vector || count == 0 || (geometry.n_dot_h != nullptr && geometry.v_dot_h != nullptr),
        "SampleSet::AddTerms: a half_vector set needs the terms' n.h and v.h");
  Check(half_vector ? n_dot_v.size() == size() && n_dot_h.size() == light.size() && v_dot_h.size() == light.size()
                    : n_dot_v.empty() && n_dot_h.empty() && v_dot_h.empty(),
        "SampleSet::AddTerms: half-vector arrays do not match the half_vector flag");
  element.push_back(element_id);
  frame.push_back(static_cast<uint16_t>(frame_index));
  camera.push_back(static_cast<uint8_t>(camera_index));
  reflectance.push_back(rgb);
  if (half_vector) n_dot_v.push_back(geometry.n_dot_v);
  // The first sample with fall-off: the terms before it had a_k = 1.
  const bool with_falloff = falloff_terms != nullptr || !falloff.empty();
  if (falloff_terms != nullptr && falloff.empty()) falloff.assign(light.size(), 1.0f);
  int previous = -1;
  for (size_t j = 0; j < count; ++j) {
    Check(lights[j] < light_names.size() && static_cast<int>(lights[j]) > previous,
          "SampleSet::AddTerms: light indices must ascend below num_lights()");
    previous = lights[j];
    if (!KeepTerm(g_terms[j])) continue;
    light.push_back(lights[j]);
    g.push_back(g_terms[j]);
    h.push_back(h_terms[j]);
    if (with_falloff) falloff.push_back(falloff_terms != nullptr ? falloff_terms[j] : 1.0f);
    if (half_vector) {
      n_dot_h.push_back(geometry.n_dot_h[j]);
      v_dot_h.push_back(geometry.v_dot_h[j]);
    }
  }
  offset.push_back(light.size());
}

float SampleSet::GOf(size_t i, int k) const {
  for (size_t j = TermsBegin(i); j < TermsEnd(i); ++j) {
    if (light[j] == k) return g[j];
  }
  return 0.0f;
}

float SampleSet::HOf(size_t i, int k) const {
  for (size_t j = TermsBegin(i); j < TermsEnd(i); ++j) {
    if (light[j] == k) return h[j];
  }
  return 0.0f;
}

absl::StatusOr<LightMask> SampleSet::MaskOf(const std::vector<std::string>& names) const {
  LightMask mask;
  for (const std::string& name : names) {
    bool found = false;
    for (int k = 0; k < num_lights() && k < kMaxLights; ++k) {
      if (light_names[k] == name) {
        mask.Set(static_cast<size_t>(k));
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

glm::vec3 SampleSet::Illumination(size_t i, const LightSelection& lights) const {
  glm::vec3 sum(0.0f);
  const bool own = lights.Own(frame[i]);
  for (size_t j = TermsBegin(i); j < TermsEnd(i); ++j) {
    if (own || lights.config.Test(light[j])) sum += light_intensity[light[j]] * g[j];
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
  bytes += offset.capacity() * sizeof(uint64_t);
  bytes += light.capacity() * sizeof(uint16_t);
  bytes += g.capacity() * sizeof(float);
  bytes += h.capacity() * sizeof(float);
  bytes += falloff.capacity() * sizeof(float);
  bytes += (n_dot_v.capacity() + n_dot_h.capacity() + v_dot_h.capacity()) * sizeof(float);
  return bytes;
}

std::string EncodeSampleSet(const SampleSet& set, bool compact) {
  const size_t n = set.size();
  const size_t num = static_cast<size_t>(set.num_lights());
  const size_t terms = set.num_terms();
  Check(num <= static_cast<size_t>(kMaxLights), "EncodeSampleSet: more than kMaxLights lights");
  Check(set.light_intensity.size() == num, "EncodeSampleSet: light_intensity and light_names differ in size");
  const bool has_falloff = !set.falloff.empty();
  Check(set.frame.size() == n && set.camera.size() == n && set.reflectance.size() == n && set.offset.size() == n + 1 &&
            set.offset.front() == 0 && set.offset.back() == terms && set.g.size() == terms && set.h.size() == terms &&
            (!has_falloff || set.falloff.size() == terms) &&
            (set.half_vector ? set.n_dot_v.size() == n && set.n_dot_h.size() == terms && set.v_dot_h.size() == terms
                             : set.n_dot_v.empty() && set.n_dot_h.empty() && set.v_dot_h.empty()),
        "EncodeSampleSet: arrays of inconsistent sizes");
  const bool hv = set.half_vector;
  const size_t real = compact ? 2 : 4;
  std::string out;
  size_t names = 0;
  for (const std::string& name : set.light_names) {
    Check(name.size() <= kMaxNameBytes, "EncodeSampleSet: light name longer than 4096 bytes");
    names += 4 + name.size() + 12;
  }
  const size_t arrays = (has_falloff ? 3 : 2) + (hv ? 2 : 0);
  out.reserve(kHeaderBytes + names + n * (4 + 2 + 1 + (hv ? 4 : 3) * real + 2) + terms * (2 + arrays * real));
  Writer w(&out);
  w.Bytes(kMagic, 4);
  w.U32(kVersion);
  w.U32((compact ? kFlagCompact : 0u) | (has_falloff ? kFlagFalloff : 0u) | (hv ? kFlagHalfVector : 0u));
  w.U32(static_cast<uint32_t>(num));
  w.U64(n);
  w.U64(terms);
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
  for (size_t i = 0; i < n; ++i) {
    const uint64_t count = set.offset[i + 1] - set.offset[i];
    Check(set.offset[i + 1] >= set.offset[i] && count <= num, "EncodeSampleSet: a sample with more terms than lights");
    w.U16(static_cast<uint16_t>(count));
  }
  for (uint16_t k : set.light) w.U16(k);
  for (float v : set.g) w.Real(v, compact);
  for (float v : set.h) w.Real(v, compact);
  for (float v : set.falloff) w.Real(v, compact);
  for (float v : set.n_dot_v) w.Real(v, compact);
  for (float v : set.n_dot_h) w.Real(v, compact);
  for (float v : set.v_dot_h) w.Real(v, compact);
  return out;
}

namespace {

// The header of an encoding, its light table and the arrays' byte count
// checked; `r` is left at the arrays.
absl::StatusOr<SampleSetHeader> ReadHeader(absl::string_view bytes, Reader& r) {
  if (!r.Has(4)) return Truncated("magic", 0, 4, r.remaining());
  if (std::memcmp(bytes.data(), kMagic, 4) != 0) {
    return absl::DataLossError("sample set encoding: bad magic (expected \"MVSS\"): not a sample set");
  }
  r.Take(4);
  if (!r.Has(4)) return Truncated("header", r.position(), 4, r.remaining());
  SampleSetHeader header;
  const uint32_t version = r.U32();
  if (version == 1) {
    return absl::DataLossError(
        "sample set encoding: version 1 (dense rows of at most 16 lights) is no longer read; this build reads version "
        "2 and 3 (recompute the Samples)");
  }
  if (version != 2 && version != kVersion) {
    return absl::DataLossError(absl::StrCat("sample set encoding: unknown version ", version,
                                            " (this build reads versions 2 and ", kVersion, ")"));
  }
  if (!r.Has(kHeaderBytes - 8)) return Truncated("header", r.position(), kHeaderBytes - 8, r.remaining());
  const uint32_t flags = r.U32();
  if (flags & ~(version == 2 ? kKnownFlags & ~kFlagHalfVector : kKnownFlags)) {
    return absl::DataLossError(
        absl::StrCat("sample set encoding: unknown flags 0x", absl::Hex(flags), " for version ", version));
  }
  header.compact = (flags & kFlagCompact) != 0;
  header.has_falloff = (flags & kFlagFalloff) != 0;
  header.half_vector = (flags & kFlagHalfVector) != 0;
  const uint32_t num_lights = r.U32();
  if (num_lights > static_cast<uint32_t>(kMaxLights)) {
    return absl::DataLossError(
        absl::StrCat("sample set encoding: light count ", num_lights, " exceeds the maximum ", kMaxLights));
  }
  const uint64_t num_samples = r.U64();
  const uint64_t num_terms = r.U64();

  header.light_names.reserve(num_lights);
  header.light_intensity.reserve(num_lights);
  for (uint32_t k = 0; k < num_lights; ++k) {
    if (!r.Has(4)) return Truncated("light name length", r.position(), 4, r.remaining());
    const uint32_t length = r.U32();
    if (length > kMaxNameBytes) {
      return absl::DataLossError(absl::StrCat("sample set encoding: light ", k, " name length ", length,
                                              " exceeds the maximum ", kMaxNameBytes));
    }
    if (!r.Has(length + size_t{12})) return Truncated("light", r.position(), length + size_t{12}, r.remaining());
    header.light_names.emplace_back(r.Take(length));
    glm::vec3 intensity;
    for (int c = 0; c < 3; ++c) intensity[c] = r.F32();
    header.light_intensity.push_back(intensity);
  }

  // The arrays must fill the rest of the buffer exactly. Check the counts
  // against the remaining bytes before allocating anything from them.
  const size_t real = header.compact ? 2 : 4;
  const size_t per_sample = 4 + 2 + 1 + (header.half_vector ? 4 : 3) * real + 2;
  const size_t per_term = 2 + ((header.has_falloff ? 3 : 2) + (header.half_vector ? 2 : 0)) * real;
  const size_t left = r.remaining();
  if (num_samples > left / per_sample || num_terms > left / per_term ||
      num_samples * per_sample > left - num_terms * per_term) {
    return absl::DataLossError(absl::StrCat("sample set encoding: truncated arrays: ", num_samples, " samples x ",
                                            per_sample, " bytes and ", num_terms, " terms x ", per_term, " bytes, but ",
                                            left, " bytes left"));
  }
  header.num_samples = static_cast<size_t>(num_samples);
  header.num_terms = static_cast<size_t>(num_terms);
  const size_t n = header.num_samples, terms = header.num_terms;
  if (left != n * per_sample + terms * per_term) {
    return absl::DataLossError(absl::StrCat("sample set encoding: counts inconsistent with the buffer: ", n,
                                            " samples x ", per_sample, " bytes + ", terms, " terms x ", per_term,
                                            " bytes = ", n * per_sample + terms * per_term, ", but ", left,
                                            " bytes follow the header"));
  }
  // EncodeSampleSet sets the flag only for a non-empty falloff array, so one
  // set has one encoding (found by tests/fuzz/sample_set_fuzz: the flag with
  // no terms decoded, and re-encoded without it).
  if (header.has_falloff && terms == 0) {
    return absl::DataLossError("sample set encoding: falloff flag set but there are no terms");
  }
  return header;
}

}  // namespace

absl::StatusOr<SampleSetHeader> ReadSampleSetHeader(absl::string_view bytes) {
  Reader r(bytes);
  return ReadHeader(bytes, r);
}

absl::StatusOr<SampleSet> DecodeSampleSet(absl::string_view bytes) {
  Reader r(bytes);
  MVBRDF_ASSIGN_OR_RETURN(SampleSetHeader header, ReadHeader(bytes, r));
  const bool compact = header.compact;
  const bool has_falloff = header.has_falloff;
  const bool hv = header.half_vector;
  const uint32_t num_lights = static_cast<uint32_t>(header.light_names.size());
  const size_t n = header.num_samples;
  const size_t terms = header.num_terms;
  SampleSet set;
  set.light_names = std::move(header.light_names);
  set.light_intensity = std::move(header.light_intensity);
  set.element.resize(n);
  set.frame.resize(n);
  set.camera.resize(n);
  set.reflectance.resize(n);
  set.offset.resize(n + 1);
  set.light.resize(terms);
  set.g.resize(terms);
  set.h.resize(terms);
  if (has_falloff) set.falloff.resize(terms);
  set.half_vector = hv;
  if (hv) {
    set.n_dot_v.resize(n);
    set.n_dot_h.resize(terms);
    set.v_dot_h.resize(terms);
  }
  for (size_t i = 0; i < n; ++i) set.element[i] = r.U32();
  for (size_t i = 0; i < n; ++i) set.frame[i] = r.U16();
  for (size_t i = 0; i < n; ++i) set.camera[i] = r.U8();
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) set.reflectance[i][c] = r.Real(compact);
  }
  set.offset[0] = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint16_t count = r.U16();
    if (count > num_lights) {
      return absl::DataLossError(absl::StrCat("sample set encoding: sample ", i, " has ", count,
                                              " terms, more than the ", num_lights, " lights"));
    }
    set.offset[i + 1] = set.offset[i] + count;
  }
  if (set.offset[n] != terms) {
    return absl::DataLossError(absl::StrCat("sample set encoding: the samples' term counts add up to ", set.offset[n],
                                            ", the header says ", terms, " terms"));
  }
  for (size_t i = 0; i < n; ++i) {
    int previous = -1;
    for (uint64_t j = set.offset[i]; j < set.offset[i + 1]; ++j) {
      const uint16_t k = r.U16();
      if (k >= num_lights || static_cast<int>(k) <= previous) {
        return absl::DataLossError(absl::StrCat("sample set encoding: sample ", i, " term ", j - set.offset[i],
                                                ": light ", k, " is not ascending below ", num_lights));
      }
      set.light[j] = k;
      previous = k;
    }
  }
  for (float& v : set.g) v = r.Real(compact);
  for (float& v : set.h) v = r.Real(compact);
  for (float& v : set.falloff) v = r.Real(compact);
  for (float& v : set.n_dot_v) v = r.Real(compact);
  for (float& v : set.n_dot_h) v = r.Real(compact);
  for (float& v : set.v_dot_h) v = r.Real(compact);
  return set;
}

}  // namespace mvbrdf::samples
