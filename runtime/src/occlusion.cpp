// occlusion.cpp — see occlusion.h for the reference [1] and the tile's definition.
#include "drtv/runtime/occlusion.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "drtv/formats/quantize.h"
#include "world_limits.h"

namespace drtv::runtime {
namespace {
using detail::kMaxWorldM;

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

std::array<uint32_t, OcclusionTile::kTexels> OcclusionTile::toRgba8() const {
  std::array<uint32_t, kTexels> out{};
  for (int i = 0; i < kTexels; ++i) out[i] = uint32_t(sky_visibility[i]) | uint32_t(occluder_height[i]) << 8;
  return out;
}

OcclusionTile makeOcclusionTile(const Sector& s) {
  OcclusionTile t;
  t.key = s.key;
  constexpr int D = kOcclusionTileDim;
  if (s.has_ground) {
    t.ground_z_min_m = s.ground_z_min_m;
    t.ground_z_max_m = s.ground_z_max_m;
    t.ground = s.ground;
  }
  if (s.probes.empty()) {
    t.sky_visibility.fill(255);
    t.occluder_height.fill(0);
    if (!s.has_ground) t.ground_z_min_m = t.ground_z_max_m = s.grid.z_min_m;
    return t;
  }
  // Per probe once: its horizontal position, visibility, height over the terrain and base.
  constexpr int kMax = kMaxProbesPerSector;
  float px[kMax], py[kMax], vis[kMax], height[kMax], base[kMax];
  const int n = int(std::min<size_t>(s.probes.size(), kMax));
  for (int i = 0; i < n; ++i) {
    const ProbeRecord& p = s.probes[i];
    px[i] = p.position[0];
    py[i] = p.position[1];
    vis[i] = std::min(1.f, (dequantizeUnorm16(p.sky_vis[0]) + dequantizeUnorm16(p.sky_vis[1]) + dequantizeUnorm16(p.sky_vis[2])) /
                               (3.f * kOpenGroundSkyVisibility));
    if (s.has_ground) {
      const int gx = std::clamp(int(p.position[0] / float(kOcclusionTexelM)), 0, kGroundDim - 1);
      const int gy = std::clamp(int(p.position[1] / float(kOcclusionTexelM)), 0, kGroundDim - 1);
      height[i] = std::max(0.f, p.position[2] - s.groundHeight(gx, gy));
    } else {
      height[i] = float(p.height_cm) / 100.f;
    }
    base[i] = p.position[2] - height[i];
  }
  // The Gaussian is separable: exp(-(dx^2 + dy^2) / 2s^2) = g(dx) g(dy): 16 table lookups per
  // probe instead of 64 exponentials. The sums are then small matrix products,
  // W[y][x] = sum_i gy_i[y] gx_i[x] (and the same with gx scaled by visibility, height or base),
  // accumulated a texel row at a time in registers over the probes.
  float gx[kMax][D], gy[kMax][D], gxv[kMax][D], gxh[kMax][D], gxb[kMax][D];
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < D; ++k) {
      const float c = float((k + 0.5) * kOcclusionTexelM);
      gx[i][k] = gaussian(px[i] - c);
      gy[i][k] = gaussian(py[i] - c);
      gxv[i][k] = gx[i][k] * vis[i];
      gxh[i][k] = gx[i][k] * height[i];
      gxb[i][k] = gx[i][k] * base[i];
    }
  float w_sum[D * D], v_sum[D * D], h_sum[D * D], b_sum[D * D] = {};
  auto accumulate = [&]<bool kBases>() {  // the bases only matter without a ground map
    for (int y = 0; y < D; ++y) {
      float w[D] = {}, v[D] = {}, h[D] = {}, b[D] = {};
      for (int i = 0; i < n; ++i) {
        const float a = gy[i][y];
        for (int x = 0; x < D; ++x) {
          w[x] += a * gx[i][x];
          v[x] += a * gxv[i][x];
          h[x] += a * gxh[i][x];
          if constexpr (kBases) b[x] += a * gxb[i][x];
        }
      }
      for (int x = 0; x < D; ++x) w_sum[y * D + x] = w[x], v_sum[y * D + x] = v[x], h_sum[y * D + x] = h[x], b_sum[y * D + x] = b[x];
    }
  };
  if (s.has_ground)
    accumulate.template operator()<false>();
  else
    accumulate.template operator()<true>();
  float ground[D * D];
  for (int y = 0; y < D; ++y)
    for (int x = 0; x < D; ++x) {
      const int j = y * D + x;
      float v, h, g;
      if (w_sum[j] >= kMinSplatWeight) {
        v = v_sum[j] / w_sum[j];
        h = h_sum[j] / w_sum[j];
        g = b_sum[j] / w_sum[j];
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
        g = base[nearest];
      }
      t.sky_visibility[j] = toUnorm8(v);
      t.occluder_height[j] = toUnorm8(h / kOcclusionHeightRangeM);
      ground[j] = g;
    }
  if (!s.has_ground) {
    // The probes' bases, quantised over their own range.
    const auto [lo, hi] = std::minmax_element(ground, ground + D * D);
    t.ground_z_min_m = *lo;
    t.ground_z_max_m = *hi;
    const float range = *hi - *lo;
    for (int j = 0; j < D * D; ++j) t.ground[j] = range > 0.f ? quantizeUnorm16((ground[j] - *lo) / range) : 0;
  }
  return t;
}

void OcclusionMap::add(OcclusionTile tile) { tiles_[tile.key] = std::move(tile); }
bool OcclusionMap::remove(SectorKey key) { return tiles_.erase(key) > 0; }
const OcclusionTile* OcclusionMap::find(SectorKey key) const {
  auto it = tiles_.find(key);
  return it == tiles_.end() ? nullptr : &it->second;
}

float OcclusionMap::occlusion(const glm::dvec3& position) const {
  if (!(std::fabs(position.x) < kMaxWorldM && std::fabs(position.y) < kMaxWorldM && std::isfinite(position.z))) return 1.f;
  // Bilinear between texel centres; each corner texel may belong to another sector's tile.
  const double u = position.x / kOcclusionTexelM - 0.5, v = position.y / kOcclusionTexelM - 0.5;
  const double u0 = std::floor(u), v0 = std::floor(v);
  const float fu = float(u - u0), fv = float(v - v0);
  float acc = 0.f;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int64_t gx = int64_t(u0) + dx, gy = int64_t(v0) + dy;
      const int64_t sx = gx >= 0 ? gx / kOcclusionTileDim : (gx - kOcclusionTileDim + 1) / kOcclusionTileDim;
      const int64_t sy = gy >= 0 ? gy / kOcclusionTileDim : (gy - kOcclusionTileDim + 1) / kOcclusionTileDim;
      const float w = (dx ? fu : 1.f - fu) * (dy ? fv : 1.f - fv);
      float occ = 1.f;
      if (const OcclusionTile* t = find({int32_t(sx), int32_t(sy)})) {
        const int tx = int(gx - sx * kOcclusionTileDim), ty = int(gy - sy * kOcclusionTileDim);
        const float vis = t->visibility(tx, ty);
        const float h = float(position.z) - t->groundM(tx, ty);
        const float s = std::clamp(h / std::max(t->heightM(tx, ty), kMinOccluderHeightM), 0.f, 1.f);
        occ = vis + (1.f - vis) * s;
      }
      acc += w * occ;
    }
  return std::clamp(acc, 0.f, 1.f);
}

glm::vec3 distantAmbient(const OcclusionMap& map, const sh::Sh4Rgb& sky_sh, const glm::dvec3& position,
                         const glm::vec3& normal) {
  const sh::Sh4 lobe = sh::cosineLobe(normal);
  const glm::vec3 sky(std::max(0.f, glm::dot(lobe, sky_sh[0])), std::max(0.f, glm::dot(lobe, sky_sh[1])),
                      std::max(0.f, glm::dot(lobe, sky_sh[2])));
  return sky * map.occlusion(position);
}

}  // namespace drtv::runtime
