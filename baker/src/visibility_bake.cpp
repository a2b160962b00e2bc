// visibility_bake.cpp — see visibility_bake.h.
#include "visibility_bake.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include "drtv/formats/error.h"
#include "drtv/formats/visibility.h"
#include "static_rays.h"

namespace drtv::baker {

namespace {

constexpr int kMaxPassThrough = 64;  // vegetation layers a ray may pass before it counts as open

// The directions and each texel's taps for one ray count, built once per count (a table of 4,096
// rays costs a million pow() calls: not per sector).
struct Tap {
  int ray;
  double w;
};
struct Tables {
  std::vector<glm::vec3> dirs;
  std::array<std::vector<Tap>, kVisTexels> taps;
};
const Tables& tablesFor(int n) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<Tables>> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<Tables>& t = cache[n];
  if (!t) {
    t = std::make_unique<Tables>();
    for (int i = 0; i < n; ++i) t->dirs.push_back(detail::fibonacciDirection(i, n));
    // Per texel, the rays of its lobe and their weights (those above 1e-6 of the centre's).
    for (int k = 0; k < kVisTexels; ++k) {
      const glm::vec3 c = visTexelDirection(k % kVisDim, k / kVisDim);
      for (int i = 0; i < n; ++i) {
        const double w = std::pow(std::max(0.0, double(glm::dot(c, t->dirs[size_t(i)]))), double(kVisSharpness));
        if (w > 1e-6) t->taps[size_t(k)].push_back({i, w});
      }
    }
  }
  return *t;
}

// The highest static surface over each kVisOpeningCellM cell of a square around some positions,
// found by one ray down per cell when first asked (a point under it is covered).
class CoverMap {
 public:
  CoverMap(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, std::span<const glm::vec3> positions,
           uint64_t& rays)
      : scene_(scene), geometry_(geometry), rays_(rays) {
    glm::vec2 lo(INFINITY), hi(-INFINITY);
    for (const glm::vec3& p : positions) lo = glm::min(lo, glm::vec2(p)), hi = glm::max(hi, glm::vec2(p));
    origin_ = lo - glm::vec2(kVisRangeM + kVisOpeningCellM);
    const glm::ivec2 n = glm::ivec2(glm::ceil((hi - lo + glm::vec2(2.f * (kVisRangeM + kVisOpeningCellM))) / kVisOpeningCellM));
    dim_ = glm::max(n, glm::ivec2(1));
    top_.assign(size_t(dim_.x) * size_t(dim_.y), kUnknown);
  }

  // Whether static geometry stands straight above `p` (outside the square: not covered).
  bool covered(const glm::vec3& p) {
    const glm::ivec2 c = glm::ivec2(glm::floor((glm::vec2(p) - origin_) / kVisOpeningCellM));
    if (c.x < 0 || c.y < 0 || c.x >= dim_.x || c.y >= dim_.y) return false;
    float& top = top_[size_t(c.y) * size_t(dim_.x) + size_t(c.x)];
    if (top == kUnknown) {
      const glm::vec2 xy = origin_ + (glm::vec2(c) + 0.5f) * kVisOpeningCellM;
      const float z0 = geometry_.z_max + 1.f;
      const float d = detail::staticHitDistance(scene_, geometry_, glm::vec3(xy, z0), glm::vec3(0, 0, -1),
                                                z0 - geometry_.z_min + 1.f, kMaxPassThrough, rays_);
      top = std::isfinite(d) ? z0 - d : -INFINITY;
    }
    return p.z < top;
  }

 private:
  static constexpr float kUnknown = INFINITY;
  const raytrace::RayScene& scene_;
  const raytrace::SectorGeometry& geometry_;
  uint64_t& rays_;
  glm::vec2 origin_{0.f};
  glm::ivec2 dim_{1};
  std::vector<float> top_;
};

}  // namespace

std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, int ray_count, bool openings, uint64_t& rays) {
  DRTV_CHECK(ray_count >= kVisRaysMin && ray_count <= kVisRaysMax);
  const Tables& tables = tablesFor(ray_count);
  const std::vector<glm::vec3>& kDirs = tables.dirs;
  const std::array<std::vector<Tap>, kVisTexels>& kTaps = tables.taps;
  std::vector<uint8_t> out(positions.size() * kVisValuesPerProbe);
  std::vector<float> dist(static_cast<size_t>(ray_count));
  std::optional<CoverMap> cover;
  if (openings && !positions.empty()) cover.emplace(scene, geometry, positions, rays);
  for (size_t p = 0; p < positions.size(); ++p) {
    const bool under = cover && cover->covered(positions[p]);
    for (int i = 0; i < ray_count; ++i) {
      const glm::vec3 dir = kDirs[size_t(i)];
      float d = std::min(detail::staticHitDistance(scene, geometry, positions[p], dir, kVisRangeM, kMaxPassThrough, rays), kVisRangeM);
      if (under)
        for (float t = kVisOpeningStepM; t < d; t += kVisOpeningStepM)
          if (!cover->covered(positions[p] + t * dir)) {
            d = t;
            break;
          }
      dist[size_t(i)] = d;
    }
    for (int t = 0; t < kVisTexels; ++t) {
      double w_sum = 0.0, m1 = 0.0, m2 = 0.0;
      for (const Tap& tap : kTaps[size_t(t)]) {
        const double d = dist[size_t(tap.ray)];
        w_sum += tap.w;
        m1 += tap.w * d;
        m2 += tap.w * d * d;
      }
      const size_t o = p * kVisValuesPerProbe + size_t(t) * 2;
      const double mean = m1 / w_sum;
      const std::array<uint8_t, 2> q = encodeVisTexel(mean, std::sqrt(std::max(0.0, m2 / w_sum - mean * mean)));
      out[o] = q[0], out[o + 1] = q[1];
    }
  }
  return out;
}

}  // namespace drtv::baker
