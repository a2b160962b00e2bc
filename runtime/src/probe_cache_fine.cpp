// probe_cache_fine.cpp — part of ProbeCache (probe_cache.h): the fine level near surfaces.
#include <algorithm>
#include <cmath>
#include <span>

#include "drtv/formats/visibility.h"
#include "drtv/runtime/probe_cache.h"
#include "probe_cache_impl.h"

namespace drtv::runtime {

using namespace detail;

FineSample ProbeCache::fineLookup(const glm::dvec3& position, const glm::vec3& normal, const FineOptions& o) const {
  FineSample out;
  if (!o.enabled || !(o.radius_m > 0.f)) return out;
  const glm::dvec3 at = position + glm::dvec3(normal) * double(o.normal_bias_m);
  if (!(std::isfinite(at.x) && std::isfinite(at.y) && std::isfinite(at.z))) return out;
  const double R = o.radius_m, R2 = R * R;
  std::array<glm::vec3, 4> sum{};
  double w_sum = 0.0;
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used || sl.covered.empty()) continue;
    // Slots whose probes' bounds lie farther than R: none of theirs is in range.
    const glm::dvec3 lo(sl.origin.x + sl.lo.x - R, sl.origin.y + sl.lo.y - R, double(sl.lo.z) - R);
    const glm::dvec3 hi(sl.origin.x + sl.hi.x + R, sl.origin.y + sl.hi.y + R, double(sl.hi.z) + R);
    if (glm::any(glm::lessThan(at, lo)) || glm::any(glm::greaterThan(at, hi))) continue;
    for (size_t k = 0; k < sl.covered.size(); ++k) {
      const int i = sl.covered[k];
      const glm::vec3& q = sl.position[size_t(i)];
      const glm::dvec3 d(at.x - (sl.origin.x + q.x), at.y - (sl.origin.y + q.y), at.z - double(q.z));
      const double r2 = glm::dot(d, d);
      if (!(r2 < R2)) continue;
      const double r = std::sqrt(r2);
      const glm::vec3 dir = r > 1e-6 ? glm::vec3(d / r) : glm::vec3(0.f, 0.f, 1.f);
      const double falloff = (1.0 - r2 / R2) * (1.0 - r2 / R2);
      const double facing = 0.5 * (1.0 + double(glm::dot(-dir, normal)));
      const double back = facing * facing + 0.2;
      const std::span<const uint8_t> vis(sl.visibility.data() + k * kVisValuesPerProbe, kVisValuesPerProbe);
      const float v = visibilityWeight(vis, dir, float(r));
      if (!(v >= o.min_visibility)) continue;
      double w = falloff * back * double(v);
      if (w < 0.2) w = w * w * w / 0.04;
      if (!(w > 0.0)) continue;
      const BasisColours c = colours({int(s), i});
      for (int b = 0; b < 4; ++b) sum[size_t(b)] += float(w) * c[size_t(b)];
      w_sum += w;
      ++out.probes;
    }
  }
  if (!(w_sum > 0.0)) return out;
  for (int b = 0; b < 4; ++b) out.colours[size_t(b)] = sum[size_t(b)] / float(w_sum);
  out.weight = float(std::min(1.0, w_sum / std::max(1e-6, double(o.full_weight))));
  return out;
}

void ProbeCache::visitCoveredProbes(const glm::dvec3& lo, const glm::dvec3& hi, const std::function<void(const CoveredProbe&)>& visit) const {
  for (size_t s = 0; s < impl_->slots.size(); ++s) {
    const Slot& sl = impl_->slots[s];
    if (!sl.used || sl.covered.empty()) continue;
    const glm::dvec3 slo(sl.origin.x + sl.lo.x, sl.origin.y + sl.lo.y, double(sl.lo.z));
    const glm::dvec3 shi(sl.origin.x + sl.hi.x, sl.origin.y + sl.hi.y, double(sl.hi.z));
    if (glm::any(glm::lessThan(shi, lo)) || glm::any(glm::greaterThan(slo, hi))) continue;
    for (size_t k = 0; k < sl.covered.size(); ++k) {
      const int i = sl.covered[k];
      const glm::vec3& q = sl.position[size_t(i)];
      const glm::dvec3 p(sl.origin.x + q.x, sl.origin.y + q.y, double(q.z));
      if (glm::any(glm::lessThan(p, lo)) || glm::any(glm::greaterThan(p, hi))) continue;
      visit({p, std::span<const uint8_t>(sl.visibility.data() + k * kVisValuesPerProbe, kVisValuesPerProbe), colours({int(s), i})});
    }
  }
}

}  // namespace drtv::runtime
