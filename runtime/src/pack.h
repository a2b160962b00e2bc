// pack.h — private: the RGBA8 texel encoding shared by the probe cache and the volume fill.
#pragma once

#include <cstdint>

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

}  // namespace drtv::runtime::detail
