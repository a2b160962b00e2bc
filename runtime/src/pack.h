// pack.h — private: the RGBA8 texel encoding shared by the probe cache and the volume fill.
#pragma once

#include <cstdint>

#include "drtv/formats/representation.h"

namespace drtv::runtime::detail {

// One channel's four basis intensities as RGBA8 (B0 in the low byte), each round(255 min(1, v *
// inv_scale)); negative and NaN encode 0.
inline uint32_t packTexel(float b0, float b1, float b2, float b3, float inv_scale) {
  auto q = [inv_scale](float v) -> uint32_t {
    const float x = v * inv_scale;
    if (!(x > 0.f)) return 0;
    if (x >= 1.f) return 255;
    return uint32_t(x * 255.f + 0.5f);
  };
  return q(b0) | q(b1) << 8 | q(b2) << 16 | q(b3) << 24;
}

// One channel's band-1 irradiance SH e0..e3 as RGBA8 (representation.h, sh-l1): e0 as
// round(255 min(1, e0 * inv_scale)) (negative and NaN: 0), e1..3 as 128 + round(127 x) with
// x = e * inv_scale clamped to [-1, 1] (NaN: 128), so that byte 128 is exactly 0.
inline uint32_t packTexelShL1(float e0, float e1, float e2, float e3, float inv_scale) {
  auto s = [inv_scale](float v) -> uint32_t {
    const float x = v * inv_scale;
    if (!(x == x)) return 128;
    const float c = x < -1.f ? -1.f : (x > 1.f ? 1.f : x);
    const float r = c * 127.f;
    return uint32_t(128 + int32_t(r + (r >= 0.f ? 0.5f : -0.5f)));  // truncation: round half away
  };
  return packTexel(e0, 0.f, 0.f, 0.f, inv_scale) | s(e1) << 8 | s(e2) << 16 | s(e3) << 24;
}

inline uint32_t packTexel(Representation r, float c0, float c1, float c2, float c3, float inv_scale) {
  return r == Representation::kShL1 ? packTexelShL1(c0, c1, c2, c3, inv_scale) : packTexel(c0, c1, c2, c3, inv_scale);
}

}  // namespace drtv::runtime::detail
