// visibility.cpp — the octahedral depth-moment map (visibility.h).
#include "drtv/formats/visibility.h"

#include <algorithm>
#include <cmath>

#include "drtv/formats/error.h"

namespace drtv {

glm::vec2 octEncode(const glm::vec3& d) {
  const float l1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  glm::vec2 p = l1 > 0.f ? glm::vec2(d.x, d.y) / l1 : glm::vec2(0.f);
  if (d.z < 0.f) {
    const glm::vec2 s(p.x >= 0.f ? 1.f : -1.f, p.y >= 0.f ? 1.f : -1.f);
    p = (1.f - glm::abs(glm::vec2(p.y, p.x))) * s;
  }
  return p * 0.5f + 0.5f;
}

glm::vec3 octDecode(const glm::vec2& uv) {
  const glm::vec2 p = uv * 2.f - 1.f;
  glm::vec3 d(p.x, p.y, 1.f - std::abs(p.x) - std::abs(p.y));
  if (d.z < 0.f) {
    const glm::vec2 s(d.x >= 0.f ? 1.f : -1.f, d.y >= 0.f ? 1.f : -1.f);
    const glm::vec2 q = (1.f - glm::abs(glm::vec2(d.y, d.x))) * s;
    d.x = q.x, d.y = q.y;
  }
  return glm::normalize(d);
}

glm::vec3 visTexelDirection(int x, int y) { return octDecode((glm::vec2(x, y) + 0.5f) / float(kVisDim)); }

std::array<uint8_t, 2> encodeVisTexel(double mean, double sigma) {
  const double m = std::clamp(mean / kVisRangeM, 0.0, 1.0), s = std::clamp(sigma / kVisMaxSigmaM, 0.0, 1.0);
  return {uint8_t(std::lround(255.0 * std::sqrt(m))), uint8_t(std::lround(255.0 * s))};
}

glm::vec2 decodeVisTexel(uint8_t mean, uint8_t sigma) {
  const float q = float(mean) / 255.f;
  return {q * q * kVisRangeM, float(sigma) / 255.f * kVisMaxSigmaM};
}

glm::vec2 visMoments(std::span<const uint8_t> v, const glm::vec3& d) {
  DRTV_CHECK_EQ(v.size(), kVisValuesPerProbe);
  const glm::vec2 t = glm::clamp(octEncode(d) * float(kVisDim) - 0.5f, glm::vec2(0.f), glm::vec2(float(kVisDim - 1)));
  const int x0 = std::min(int(t.x), kVisDim - 2), y0 = std::min(int(t.y), kVisDim - 2);
  const float fx = t.x - float(x0), fy = t.y - float(y0);
  auto at = [&](int x, int y) {
    const size_t i = size_t(y * kVisDim + x) * 2;
    const glm::vec2 t = decodeVisTexel(v[i], v[i + 1]);
    return glm::vec2(t.x, t.x * t.x + t.y * t.y);
  };
  const glm::vec2 a = glm::mix(at(x0, y0), at(x0 + 1, y0), fx), b = glm::mix(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx);
  return glm::mix(a, b, fy);
}

float visibilityWeight(std::span<const uint8_t> v, const glm::vec3& d, float r) {
  const glm::vec2 m = visMoments(v, d);
  if (!(r > m.x)) return 1.f;
  const float var = std::max(m.y - m.x * m.x, kVisMinVariance);
  const float e = r - m.x;
  const float p = var / (var + e * e);
  return p * p * p;
}

}  // namespace drtv
