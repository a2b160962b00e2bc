// The seed's ground-proximity blend for the sweep's ambient lookup, and the ground height map it
// reads.
//
//  [1] ../shared/seeds/001, "Rendering": "An additional tweak is used to remove discontinuities of
//      lighting between the ground that uses surface normals and objects near the ground [...]:
//      the closer their vertices are to the ground, the more similar their lighting will be to
//      the ground lighting (e.g. diffuse lighting will appear as if the surface normal of a bush
//      was the same as the ground normal)."
//
// The blend: at a point p with normal n, height above the ground d = p.z - ground(p.xy) and a
// blend height b > 0, w = clamp(1 - d / b, 0, 1) (1 at and below the ground, 0 from b up), and
//   E = (1 - w) E(p, n) + w E(p, n_ground),
// n_ground the terrain's normal under p. So at the ground a sideways normal reads what the
// ground's normal reads there, and from b up nothing changes. Linear in the irradiances: the
// blend keeps E between the two normals' values.
//
// Thread-safety: value types; const members from any number of threads.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/glm.hpp>

namespace drtv::eval {

// The terrain's height per column of a grid (x, y), sampled at the columns' centres.
struct GroundMap {
  glm::dvec2 origin{0.0};  // world metres of the min corner of column (0, 0)
  double cell_m = 1.0;     // column edge, metres
  int nx = 0, ny = 0;      // columns per axis
  std::vector<float> z;    // per column i + nx j: world metres; NaN where no terrain was found

  bool empty() const { return z.empty(); }
  // The height at world (x, y): bilinear between the 4 column centres around it (clamped to the
  // outermost centres); NaN when any of them has no terrain.
  double heightAt(double x, double y) const;
  // The terrain's unit normal at (x, y): the bilinear surface's, by central differences one
  // column apart; +Z where heightAt is NaN nearby.
  glm::vec3 normalAt(double x, double y) const;
};

// The blend's weight at `height_above_m` over the ground, for blend height `blend_m` (> 0).
inline double groundBlendWeight(double height_above_m, double blend_m) {
  return std::clamp(1.0 - height_above_m / blend_m, 0.0, 1.0);
}

// E(p, n) blended toward E(p, n_ground) [1]; `irradiance(normal)` gives E at p for a normal.
// Unchanged without a ground map, with blend_m <= 0, or where the map has no terrain.
template <class Irradiance>
glm::vec3 blendTowardGround(const GroundMap* ground, double blend_m, const glm::dvec3& p, const glm::vec3& n,
                            const Irradiance& irradiance) {
  const glm::vec3 e = irradiance(n);
  if (!ground || ground->empty() || !(blend_m > 0)) return e;
  const double h = ground->heightAt(p.x, p.y);
  if (std::isnan(h)) return e;
  const float w = float(groundBlendWeight(p.z - h, blend_m));
  if (w <= 0.f) return e;
  return (1.f - w) * e + w * irradiance(ground->normalAt(p.x, p.y));
}

}  // namespace drtv::eval
