// visibility_bake.cpp — see visibility_bake.h.
#include "visibility_bake.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

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

}  // namespace

std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, int ray_count, uint64_t& rays) {
  DRTV_CHECK(ray_count >= kVisRaysMin && ray_count <= kVisRaysMax);
  const Tables& tables = tablesFor(ray_count);
  const std::vector<glm::vec3>& kDirs = tables.dirs;
  const std::array<std::vector<Tap>, kVisTexels>& kTaps = tables.taps;
  std::vector<uint8_t> out(positions.size() * kVisValuesPerProbe);
  std::vector<float> dist(static_cast<size_t>(ray_count));
  for (size_t p = 0; p < positions.size(); ++p) {
    for (int i = 0; i < ray_count; ++i) {
      const float d = detail::staticHitDistance(scene, geometry, positions[p], kDirs[size_t(i)], kVisRangeM, kMaxPassThrough, rays);
      dist[size_t(i)] = std::min(d, kVisRangeM);
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
