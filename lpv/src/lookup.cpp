// Cascaded light propagation volumes (lpv.h; references there): lookup: irradiance at a point,
// interpolated in a cascade and blended across them.
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <cmath>

#include "cascade.h"

namespace drtv::lpv {

using namespace detail;

namespace {
// Trilinear over the cell centres of planes [p0, p1) at cell coordinates u (clamped to the grid).
template <class Grid>
void trilinear(const Grid& g, const std::vector<float>& planes, const glm::dvec3& u, int p0, int p1, float* acc) {
  const glm::dvec3 uc = glm::clamp(u, glm::dvec3(0.0), glm::dvec3(g.n - 1));
  const glm::ivec3 i0 = glm::min(glm::ivec3(glm::floor(uc)), glm::ivec3(g.n - 2));
  const glm::vec3 f = glm::vec3(uc - glm::dvec3(i0));
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) {
        const float w = (dx ? f.x : 1.f - f.x) * (dy ? f.y : 1.f - f.y) * (dz ? f.z : 1.f - f.z);
        if (w == 0.f) continue;
        const size_t idx = g.index(i0.x + dx, i0.y + dy, i0.z + dz);
        for (int p = p0; p < p1; ++p) acc[p] += w * planes[size_t(p) * g.cells + idx];
      }
}
}  // namespace

glm::vec3 CascadedLpv::lookup(int c, const glm::dvec3& position, const glm::vec3& normal, bool sky) const {
  const Cascade& g = cascades_[size_t(c)];
  const double s = g.box.cell_m;
  const glm::dvec3 u = (position + double(options_.lookup_offset_cells) * s * glm::dvec3(normal) - g.box.min) / s - 0.5;
  const std::vector<float>& planes = sky ? g.sky : g.light;
  std::array<float, kPlanes> acc{};
  trilinear(g, planes, u, 0, kPlanes, acc.data());
  const sh::Sh4 lobe = sh::cosineLobe(sky ? normal : -normal);
  glm::vec3 e;
  for (int ch = 0; ch < 3; ++ch)
    e[ch] = lobe.x * acc[size_t(ch * 4)] + lobe.y * acc[size_t(ch * 4 + 1)] + lobe.z * acc[size_t(ch * 4 + 2)] +
            lobe.w * acc[size_t(ch * 4 + 3)];
  if (!sky && options_.damping) {
    // Damping against self-bleeding [1] (seed 003, "Final scene rendering": "dampen based on
    // the gradient's deviation from the intensity distribution's direction"): light that a
    // surface receives travels towards it, so where the cell's light mostly travels out of the
    // surface (its band-1 direction d along the normal, n.d > 0), it is the surface's own or its
    // plane's, and is scaled by 1 - n.d.
    for (int ch = 0; ch < 3; ++ch) {
      const glm::vec3 d(acc[size_t(ch * 4 + 3)], acc[size_t(ch * 4 + 1)], acc[size_t(ch * 4 + 2)]);
      const float len = glm::length(d);
      if (len > 0.f) e[ch] *= 1.f - std::max(0.f, glm::dot(normal, d) / len);
    }
  }
  return e;
}

namespace {
// The share of cascade c that a point at cell coordinates u keeps before the next cascade takes
// over: 1 deep inside, falling to 0 over `blend` cells at the border.
float keepWeight(const glm::dvec3& u, int n, float blend) {
  double edge = 1e30;
  for (int a = 0; a < 3; ++a) edge = std::min({edge, u[a] + 0.5, double(n) - 0.5 - u[a]});
  if (blend <= 0.f) return edge > 0 ? 1.f : 0.f;
  return float(std::clamp((edge - 0.5) / double(blend), 0.0, 1.0));
}
}  // namespace

glm::vec3 CascadedLpv::blended(const glm::dvec3& position, const glm::vec3& normal, bool sky) const {
  glm::vec3 out(0.f);
  float rest = 1.f;
  for (int c = 0; c < cascadeCount() && rest > 0.f; ++c) {
    const Cascade& g = cascades_[size_t(c)];
    if (!g.box.contains(position)) continue;
    const glm::dvec3 u = (position - g.box.min) / g.box.cell_m - 0.5;
    const float w = c + 1 == cascadeCount() ? 1.f : keepWeight(u, g.n, options_.blend_cells);
    if (w <= 0.f) continue;
    out += rest * w * lookup(c, position, normal, sky);
    rest *= 1.f - w;
  }
  return glm::max(out, glm::vec3(0.f));
}

glm::vec3 CascadedLpv::indirect(const glm::dvec3& position, const glm::vec3& normal) const { return blended(position, normal, false); }

glm::vec3 CascadedLpv::sky(const glm::dvec3& position, const glm::vec3& normal) const { return blended(position, normal, true); }

glm::vec3 CascadedLpv::indirectIn(int c, const glm::dvec3& position, const glm::vec3& normal) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  return glm::max(lookup(c, position, normal, false), glm::vec3(0.f));
}

glm::vec3 CascadedLpv::skyIn(int c, const glm::dvec3& position, const glm::vec3& normal) const {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  return glm::max(lookup(c, position, normal, true), glm::vec3(0.f));
}

}  // namespace drtv::lpv
