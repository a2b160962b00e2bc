// occlusion.cpp — see occlusion.h for the reference [1] and the tile's definition.
#include "drtv/runtime/occlusion.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace drtv::runtime {
namespace {
constexpr double kMaxWorldM = 1e11;  // beyond, no sector (floor(x / 64) must fit in int32)
constexpr float kFarWeightM2 = 64.f;  // (8 m)^2: the texel size, softens the 1/d^2 weights
}  // namespace

std::array<uint32_t, kOcclusionTileDim * kOcclusionTileDim> OcclusionTile::toRgba8() const {
  std::array<uint32_t, kOcclusionTileDim * kOcclusionTileDim> out{};
  for (size_t i = 0; i < out.size(); ++i) {
    const auto q = [](float v) { return uint32_t(std::clamp(v, 0.f, 1.f) * 255.f + 0.5f); };
    out[i] = q(sky_visibility[i]) | q((top_m[i] - ground_m[i]) / float(kSectorSizeM)) << 8;
  }
  return out;
}

OcclusionTile makeOcclusionTile(const Sector& sector) {
  OcclusionTile t;
  t.key = sector.key;
  const int n = int(sector.probes.size());
  std::vector<ProbeData> probes;
  probes.reserve(n);
  for (const ProbeRecord& r : sector.probes) probes.push_back(unpackProbe(r));
  float lowest_base = std::numeric_limits<float>::max();
  for (const ProbeData& p : probes) lowest_base = std::min(lowest_base, p.position.z - p.height_m);
  for (int y = 0; y < kOcclusionTileDim; ++y)
    for (int x = 0; x < kOcclusionTileDim; ++x) {
      const int i = y * kOcclusionTileDim + x;
      const glm::vec2 centre((x + 0.5f) * float(kOcclusionTexelM), (y + 0.5f) * float(kOcclusionTexelM));
      float vis_sum = 0.f, top = std::numeric_limits<float>::lowest(), base = std::numeric_limits<float>::max();
      int inside = 0;
      double w_sum = 0.0, w_vis = 0.0, w_height = 0.0;
      for (const ProbeData& p : probes) {
        const float vis = std::clamp((p.sky_vis[0] + p.sky_vis[1] + p.sky_vis[2]) / (3.f * kOpenGroundSkyVisibility), 0.f, 1.f);
        const int px = std::clamp(int(p.position.x / float(kOcclusionTexelM)), 0, kOcclusionTileDim - 1);
        const int py = std::clamp(int(p.position.y / float(kOcclusionTexelM)), 0, kOcclusionTileDim - 1);
        if (px == x && py == y) {
          vis_sum += vis;
          top = std::max(top, p.position.z);
          base = std::min(base, p.position.z - p.height_m);
          ++inside;
        }
        const glm::vec2 d = glm::vec2(p.position.x, p.position.y) - centre;
        const double w = 1.0 / (double(glm::dot(d, d)) + kFarWeightM2);
        w_sum += w;
        w_vis += w * vis;
        w_height += w * p.height_m;
      }
      float ground;
      if (sector.has_ground)
        ground = sector.groundHeight(x, y);
      else if (inside > 0)
        ground = base;
      else if (n > 0)
        ground = lowest_base;
      else
        ground = sector.grid.z_min_m;
      if (inside > 0) {
        t.sky_visibility[i] = vis_sum / float(inside);
      } else if (n > 0) {
        t.sky_visibility[i] = float(w_vis / w_sum);
        top = ground + float(w_height / w_sum);
      } else {
        t.sky_visibility[i] = 1.f;
        top = ground;
      }
      t.ground_m[i] = ground;
      t.top_m[i] = std::max(top, ground + kMinOccluderHeightM);
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
        const int i = int(gy - sy * kOcclusionTileDim) * kOcclusionTileDim + int(gx - sx * kOcclusionTileDim);
        const float h = float(position.z) - t->ground_m[i];
        const float s = std::clamp(h / (t->top_m[i] - t->ground_m[i]), 0.f, 1.f);
        occ = t->sky_visibility[i] + (1.f - t->sky_visibility[i]) * s;
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
