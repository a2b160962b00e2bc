// visibility_bake.cpp — see visibility_bake.h.
#include "visibility_bake.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "drtv/formats/visibility.h"
#include "drtv/worlds/world.h"

namespace drtv::baker {

namespace {

constexpr int kMaxPassThrough = 64;  // vegetation layers a ray may pass before it counts as open

glm::vec3 fibonacciDirection(int i, int n) {
  const double golden = 2.399963229728653;  // pi (3 - sqrt 5)
  const double z = 1.0 - (2.0 * i + 1.0) / n;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return glm::vec3(float(r * std::cos(golden * i)), float(r * std::sin(golden * i)), float(z));
}

bool isStatic(uint8_t cls) {
  return cls == uint8_t(worlds::InstanceClass::kTerrain) || cls == uint8_t(worlds::InstanceClass::kStatic);
}

}  // namespace

std::vector<uint8_t> bakeVisibility(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                     std::span<const glm::vec3> positions, uint64_t& rays) {
  static const std::array<glm::vec3, kVisRays> kDirs = [] {
    std::array<glm::vec3, kVisRays> d{};
    for (int i = 0; i < kVisRays; ++i) d[size_t(i)] = fibonacciDirection(i, kVisRays);
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
      float t = 0.f, d = kVisRangeM;
      for (int k = 0; k < kMaxPassThrough; ++k) {
        const raytrace::Hit h = scene.intersect({positions[p], t, kDirs[size_t(i)], kVisRangeM});
        ++rays;
        if (!h.hit()) break;
        if (isStatic(geometry.cls[h.prim])) {
          d = h.t;
          break;
        }
        t = std::max(h.t + 1e-4f, std::nextafter(h.t, INFINITY) * (1.f + 1e-6f));
      }
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
