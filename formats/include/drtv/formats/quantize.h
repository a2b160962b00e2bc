// drtv/formats/quantize.h — 16-bit fixed point, as the talk stores every float4 in 8 bytes [1].
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 22.
//
// Two encodings, both round-to-nearest and saturating (out-of-range input clamps, NaN encodes 0):
//  - unorm16: v in [0, 1]            -> q = round(v * 65535);          |error| <= 0.5 / 65535
//  - snorm16: v in [-range, range]   -> q = round(v / range * 32767);  |error| <= 0.5 * range / 32767
// The range of each stored quantity is documented where it is stored (probe.h, sector.h).
#pragma once

#include <cmath>
#include <cstdint>

namespace drtv {

inline constexpr float kUnorm16Max = 65535.f;
inline constexpr float kSnorm16Max = 32767.f;

// Worst-case absolute error of one round trip.
inline constexpr float unorm16MaxError() { return 0.5f / kUnorm16Max; }
inline constexpr float snorm16MaxError(float range) { return 0.5f * range / kSnorm16Max; }

inline uint16_t quantizeUnorm16(float v) {
  if (!(v > 0.f)) return 0;  // also NaN
  if (v >= 1.f) return 65535;
  return static_cast<uint16_t>(std::lround(v * kUnorm16Max));
}
inline float dequantizeUnorm16(uint16_t q) { return float(q) / kUnorm16Max; }

// `range` > 0. -32768 is never produced; it decodes below -range and readers may reject it.
inline int16_t quantizeSnorm16(float v, float range) {
  const float x = v / range;
  if (!(x == x)) return 0;
  if (x >= 1.f) return 32767;
  if (x <= -1.f) return -32767;
  return static_cast<int16_t>(std::lround(x * kSnorm16Max));
}
inline float dequantizeSnorm16(int16_t q, float range) { return float(q) * range / kSnorm16Max; }

inline constexpr float kSnorm8Max = 127.f;
inline constexpr float snorm8MaxError(float range) { return 0.5f * range / kSnorm8Max; }
// `range` > 0. -128 is never produced; readers reject it.
inline int8_t quantizeSnorm8(float v, float range) {
  const float x = v / range;
  if (!(x == x)) return 0;
  if (x >= 1.f) return 127;
  if (x <= -1.f) return -127;
  return static_cast<int8_t>(std::lround(x * kSnorm8Max));
}
inline float dequantizeSnorm8(int8_t q, float range) { return float(q) * range / kSnorm8Max; }

}  // namespace drtv
