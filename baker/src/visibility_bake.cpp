// visibility_bake.cpp — see visibility_bake.h.
#include "visibility_bake.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "drtv/formats/visibility.h"
#include "static_rays.h"

namespace drtv::baker {

namespace {

constexpr int kMaxPassThrough = 64;  // vegetation layers a ray may pass before it counts as open

}  // namespace

std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, uint64_t& rays) {
  static const std::array<glm::vec3, kVisRays> kDirs = [] {
    std::array<glm::vec3, kVisRays> d{};
    for (int i = 0; i < kVisRays; ++i) d[size_t(i)] = detail::fibonacciDirection(i, kVisRays);
    return d;
  }();
  // Per texel, the rays of its lobe and their weights (those above 1e-6 of the centre's).
  struct Tap {
    int ray;
    double w;
  };
  static const std::array<std::vector<Tap>, kVisTexels> kTaps = [] {
    std::array<std::vector<Tap>, kVisTexels> taps;
    for (int t = 0; t < kVisTexels; ++t) {
      const glm::vec3 c = visTexelDirection(t % kVisDim, t / kVisDim);
      for (int i = 0; i < kVisRays; ++i) {
        const double w = std::pow(std::max(0.0, double(glm::dot(c, kDirs[size_t(i)]))), double(kVisSharpness));
        if (w > 1e-6) taps[size_t(t)].push_back({i, w});
      }
    }
    return taps;
  }();
  std::vector<uint8_t> out(positions.size() * kVisValuesPerProbe);
  std::array<float, kVisRays> dist{};
  for (size_t p = 0; p < positions.size(); ++p) {
    for (int i = 0; i < kVisRays; ++i) {
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
