// IEEE 754 binary16 ("half") <-> binary32 conversion for the compact sample
// encoding. Rounding is to nearest, ties to even; values beyond the half range
// (|x| >= 65520) become infinities; NaN stays NaN (quiet). Portable integer
// code: no F16C or _Float16 needed.
#ifndef MVBRDF_CORE_SAMPLES_HALF_FLOAT_H_
#define MVBRDF_CORE_SAMPLES_HALF_FLOAT_H_

#include <cstdint>
#include <cstring>

namespace mvbrdf::samples {

inline uint16_t FloatToHalf(float value) {
  uint32_t x;
  std::memcpy(&x, &value, 4);
  const uint16_t sign = static_cast<uint16_t>((x >> 16) & 0x8000u);
  x &= 0x7fffffffu;
  if (x >= 0x7f800000u) {  // Inf or NaN; a NaN keeps its top payload bits and is made quiet.
    return static_cast<uint16_t>(sign | 0x7c00u | (x > 0x7f800000u ? 0x0200u | ((x >> 13) & 0x03ffu) : 0u));
  }
  if (x >= 0x477ff000u) return static_cast<uint16_t>(sign | 0x7c00u);  // rounds to infinity
  const uint32_t exponent = x >> 23;
  if (exponent < 113) {  // below 2^-14: a half subnormal or zero
    if (exponent < 102) return sign;  // below 2^-25: rounds to zero (2^-25 exactly is a tie, to even 0)
    const uint32_t mantissa = (x & 0x007fffffu) | 0x00800000u;
    const uint32_t shift = 126 - exponent;  // 14..24
    uint32_t result = mantissa >> shift;
    const uint32_t rest = mantissa & ((1u << shift) - 1);
    const uint32_t half_way = 1u << (shift - 1);
    if (rest > half_way || (rest == half_way && (result & 1u))) ++result;
    return static_cast<uint16_t>(sign | result);
  }
  uint32_t result = ((exponent - 112) << 10) | ((x >> 13) & 0x03ffu);
  const uint32_t rest = x & 0x1fffu;
  if (rest > 0x1000u || (rest == 0x1000u && (result & 1u))) ++result;  // a carry moves into the exponent
  return static_cast<uint16_t>(sign | result);
}

inline float HalfToFloat(uint16_t half) {
  const uint32_t sign = static_cast<uint32_t>(half & 0x8000u) << 16;
  const uint32_t exponent = (half >> 10) & 0x1fu;
  uint32_t mantissa = half & 0x03ffu;
  uint32_t bits;
  if (exponent == 0) {
    if (mantissa == 0) {
      bits = sign;
    } else {  // subnormal: normalise
      int e = -1;
      do {
        ++e;
        mantissa <<= 1;
      } while ((mantissa & 0x0400u) == 0);
      bits = sign | ((112u - static_cast<uint32_t>(e)) << 23) | ((mantissa & 0x03ffu) << 13);
    }
  } else if (exponent == 31) {
    bits = sign | 0x7f800000u | (mantissa << 13);
  } else {
    bits = sign | ((exponent + 112) << 23) | (mantissa << 13);
  }
  float value;
  std::memcpy(&value, &bits, 4);
  return value;
}

}  // namespace mvbrdf::samples

#endif  // MVBRDF_CORE_SAMPLES_HALF_FLOAT_H_
