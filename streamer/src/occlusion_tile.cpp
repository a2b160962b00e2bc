// Distant-occlusion tiles from probe sky visibility and heights (occlusion_tile.h, talk slide 58).
#include "drtv/streamer/occlusion_tile.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "drtv/formats/quantize.h"
#include "drtv/runtime/occlusion.h"

namespace drtv::streamer {
namespace {

// Round half away from zero, as lround, without the library call (v * 255 + 0.5 >= 0.5 here).
uint8_t toUnorm8(float v) { return uint8_t(int(std::clamp(v, 0.f, 1.f) * 255.f + 0.5f)); }

// exp(-d^2 / 2 sigma^2) tabulated over |d| in [0, 64] m at 1/32 m: the largest slope of the
// Gaussian is 0.076 per metre (at d = sigma), so nearest-entry lookup errs by < 0.0012, well under
// the half unorm8 step (0.002) the tile stores. Built once; 2049 floats.
constexpr int kExpTableSteps = 32;  // per metre
const float* gaussianTable() {
  static const auto table = [] {
    std::array<float, 64 * kExpTableSteps + 1> t{};
    for (size_t i = 0; i < t.size(); ++i) {
      const double d = double(i) / kExpTableSteps;
      t[i] = float(std::exp(-d * d / (2.0 * kOcclusionSplatSigmaM * kOcclusionSplatSigmaM)));
    }
    return t;
  }();
  return table.data();
}
float gaussian(float d_m) {
  const int i = std::min(int(std::abs(d_m) * kExpTableSteps + 0.5f), 64 * kExpTableSteps);
  return gaussianTable()[i];
}

// Below this total weight a texel is farther than ~3.5 sigma from every probe: use the nearest.
constexpr float kMinSplatWeight = 1e-5f;

}  // namespace

OcclusionTile buildOcclusionTile(const Sector& s) {
  OcclusionTile t;
  t.key = s.key;
  if (s.probes.empty()) {
    t.sky_visibility.fill(255);
    t.occluder_height.fill(0);
    return t;
  }
  // Per probe once: its horizontal position, visibility and height over the terrain.
  constexpr int kMax = kMaxProbesPerSector;
  float px[kMax], py[kMax], vis[kMax], height[kMax];
  const int n = int(std::min<size_t>(s.probes.size(), kMax));
  for (int i = 0; i < n; ++i) {
    const ProbeRecord& p = s.probes[i];
    px[i] = p.position[0];
    py[i] = p.position[1];
    // Relative to open ground, as runtime/occlusion.h: the distant sky SH has no light below the horizon.
    vis[i] = std::min(1.f, (dequantizeUnorm16(p.sky_vis[0]) + dequantizeUnorm16(p.sky_vis[1]) + dequantizeUnorm16(p.sky_vis[2])) /
                               (3.f * runtime::kOpenGroundSkyVisibility));
    if (s.has_ground) {
      const int gx = std::clamp(int(p.position[0] / float(kOcclusionTexelM)), 0, kGroundDim - 1);
      const int gy = std::clamp(int(p.position[1] / float(kOcclusionTexelM)), 0, kGroundDim - 1);
      height[i] = std::max(0.f, p.position[2] - s.groundHeight(gx, gy));
    } else {
      height[i] = float(p.height_cm) / 100.f;
    }
  }
  // The Gaussian is separable: exp(-(dx^2 + dy^2) / 2s^2) = g(dx) g(dy): 16 table lookups per
  // probe instead of 64 exponentials (the tile is built for every streamed sector, on the I/O
  // thread). The sums are then three small matrix products, W[y][x] = sum_i gy_i[y] gx_i[x] (and
  // the same with gx scaled by visibility or height), accumulated a texel row at a time in
  // registers over the probes.
  constexpr int D = kOcclusionTileDim;
  float gx[kMax][D], gy[kMax][D], gxv[kMax][D], gxh[kMax][D];
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < D; ++k) {
      const float c = float((k + 0.5) * kOcclusionTexelM);
      gx[i][k] = gaussian(px[i] - c);
      gy[i][k] = gaussian(py[i] - c);
      gxv[i][k] = gx[i][k] * vis[i];
      gxh[i][k] = gx[i][k] * height[i];
    }
  float w_sum[D * D], v_sum[D * D], h_sum[D * D];
  for (int y = 0; y < D; ++y) {
    float w[D] = {}, v[D] = {}, h[D] = {};
    for (int i = 0; i < n; ++i) {
      const float a = gy[i][y];
      for (int x = 0; x < D; ++x) {
        w[x] += a * gx[i][x];
        v[x] += a * gxv[i][x];
        h[x] += a * gxh[i][x];
      }
    }
    for (int x = 0; x < D; ++x) w_sum[y * D + x] = w[x], v_sum[y * D + x] = v[x], h_sum[y * D + x] = h[x];
  }
  for (int y = 0; y < kOcclusionTileDim; ++y)
    for (int x = 0; x < kOcclusionTileDim; ++x) {
      const int j = y * kOcclusionTileDim + x;
      float v, h;
      if (w_sum[j] >= kMinSplatWeight) {
        v = v_sum[j] / w_sum[j];
        h = h_sum[j] / w_sum[j];
      } else {
        // Far from every probe (> ~3.5 sigma): the nearest probe's values.
        const float cx = float((x + 0.5) * kOcclusionTexelM), cy = float((y + 0.5) * kOcclusionTexelM);
        int nearest = 0;
        float best = INFINITY;
        for (int i = 0; i < n; ++i) {
          const float d2 = (px[i] - cx) * (px[i] - cx) + (py[i] - cy) * (py[i] - cy);
          if (d2 < best) best = d2, nearest = i;
        }
        v = vis[nearest];
        h = height[nearest];
      }
      t.sky_visibility[j] = toUnorm8(v);
      t.occluder_height[j] = toUnorm8(h / kOcclusionHeightRangeM);
    }
  return t;
}

}  // namespace drtv::streamer
