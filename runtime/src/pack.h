// pack.h — private: the RGBA8 texel encoding shared by the probe cache and the volume fill.
#pragma once

#include <cstdint>

#include "drtv/formats/representation.h"

namespace drtv::runtime::detail {

// The encodings are written without branches, so that loops over planes of them vectorise
// (ProbeCache::packSlot).
//
// One unsigned byte: round(255 min(1, v * inv_scale)); negative and NaN encode 0.
inline uint32_t packUnorm(float v, float inv_scale) {
  float x = v * inv_scale;
  x = x > 0.f ? x : 0.f;  // NaN too
  x = x < 1.f ? x : 1.f;
  return uint32_t(x * 255.f + 0.5f);
}
// One offset-binary byte: 128 + round(127 x), x = v * inv_scale clamped to [-1, 1], half away
// from zero; NaN encodes 128 (byte 128 is exactly 0).
inline uint32_t packSnormOffset(float v, float inv_scale) {
  float x = v * inv_scale;
  x = x == x ? x : 0.f;
  x = x < -1.f ? -1.f : (x > 1.f ? 1.f : x);
  const float r = x * 127.f;
  return uint32_t(128 + int32_t(r + (r >= 0.f ? 0.5f : -0.5f)));  // truncation: round half away
}

// One channel's four basis intensities as RGBA8 (B0 in the low byte), each packUnorm.
inline uint32_t packTexel(float b0, float b1, float b2, float b3, float inv_scale) {
  return packUnorm(b0, inv_scale) | packUnorm(b1, inv_scale) << 8 | packUnorm(b2, inv_scale) << 16 | packUnorm(b3, inv_scale) << 24;
}

// One channel's band-1 irradiance SH e0..e3 as RGBA8 (representation.h, sh-l1): e0 as
// round(255 min(1, e0 * inv_scale)) (negative and NaN: 0), e1..3 as 128 + round(127 x) with
// x = e * inv_scale clamped to [-1, 1] (NaN: 128), so that byte 128 is exactly 0.
inline uint32_t packTexelShL1(float e0, float e1, float e2, float e3, float inv_scale) {
  return packUnorm(e0, inv_scale) | packSnormOffset(e1, inv_scale) << 8 | packSnormOffset(e2, inv_scale) << 16 |
         packSnormOffset(e3, inv_scale) << 24;
}

inline uint32_t packTexel(Representation r, float c0, float c1, float c2, float c3, float inv_scale) {
  return r == Representation::kShL1 ? packTexelShL1(c0, c1, c2, c3, inv_scale) : packTexel(c0, c1, c2, c3, inv_scale);
}

}  // namespace drtv::runtime::detail
