#include "drtv/sweep/grid.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/packing.hpp>

#include "small_float.h"

namespace drtv::sweep {
namespace {

template <class Get>
auto trilinear(const GridShape& g, const glm::dvec3& p, Get get) {
  const glm::dvec3 u = (p - g.origin) / g.cell_m - 0.5;
  glm::ivec3 i0;
  glm::vec3 f;
  for (int a = 0; a < 3; ++a) {
    const double c = std::clamp(u[a], 0.0, double(g.size[a] - 1));
    i0[a] = std::min(int(std::floor(c)), g.size[a] - 1);
    f[a] = float(c - i0[a]);
  }
  const glm::ivec3 i1 = glm::min(i0 + 1, g.size - 1);
  using T = decltype(get(size_t(0)));
  T out = get(g.index(i0.x, i0.y, i0.z)) * ((1 - f.x) * (1 - f.y) * (1 - f.z));
  out += get(g.index(i1.x, i0.y, i0.z)) * (f.x * (1 - f.y) * (1 - f.z));
  out += get(g.index(i0.x, i1.y, i0.z)) * ((1 - f.x) * f.y * (1 - f.z));
  out += get(g.index(i1.x, i1.y, i0.z)) * (f.x * f.y * (1 - f.z));
  out += get(g.index(i0.x, i0.y, i1.z)) * ((1 - f.x) * (1 - f.y) * f.z);
  out += get(g.index(i1.x, i0.y, i1.z)) * (f.x * (1 - f.y) * f.z);
  out += get(g.index(i0.x, i1.y, i1.z)) * ((1 - f.x) * f.y * f.z);
  out += get(g.index(i1.x, i1.y, i1.z)) * (f.x * f.y * f.z);
  return out;
}

struct Vec26 {
  LightVector v{};
  Vec26 operator*(float w) const {
    Vec26 o;
    for (int k = 0; k < kDirections; ++k) o.v[size_t(k)] = v[size_t(k)] * w;
    return o;
  }
  Vec26& operator+=(const Vec26& b) {
    for (int k = 0; k < kDirections; ++k) v[size_t(k)] += b.v[size_t(k)];
    return *this;
  }
};

}  // namespace

uint32_t packR11G11B10(const glm::vec3& rgb) { return detail::packR11G11B10(rgb.r, rgb.g, rgb.b); }

glm::vec3 unpackR11G11B10(uint32_t bits) {
  return {detail::unpackSmall<6>(bits & 0x7ffu), detail::unpackSmall<6>((bits >> 11) & 0x7ffu), detail::unpackSmall<5>(bits >> 22)};
}

LightVector LightGrid::cell(size_t index) const {
  LightVector out;
  if (!unpacked.empty()) {
    std::copy_n(unpacked.begin() + std::ptrdiff_t(index * kDirections), kDirections, out.begin());
    return out;
  }
  const uint32_t* c = light.data() + index * kDirections;
  for (int k = 0; k < kDirections; ++k) out[size_t(k)] = unpackR11G11B10(c[k]);
  return out;
}

LightVector LightGrid::sample(const glm::dvec3& p) const {
  return trilinear(shape, p, [&](size_t i) { return Vec26{cell(i)}; }).v;
}

glm::vec3 LightGrid::averageLight(const glm::dvec3& p) const {
  return trilinear(shape, p, [&](size_t i) { return unpackR11G11B10(average[i]); });
}

glm::vec3 LightGrid::dominantDirection(const glm::dvec3& p) const {
  return trilinear(shape, p, [&](size_t i) { return glm::vec3(glm::unpackSnorm4x8(dominant[i])); });
}

}  // namespace drtv::sweep
