// drtv/sweep/grid.h — the material grid and the light grid of the top-down sweep (seed 001), and
// the light grid's compact stored form.
//
//  [1] ../shared/seeds/001, "Material representation": per cell an RGB diffuse reflectance and a
//      density; "Light grid format": 26 directions per cell as R11G11B10 floats, an average-light
//      grid and a dominant-direction grid; "Rendering": trilinear interpolation between the 8
//      cell centres around a point.
//  [2] OpenGL 4.6 core profile, sec. 2.3.4.3-2.3.4.4 (unsigned 11- and 10-bit floats: 5-bit
//      exponent, bias 15, 6 or 5 mantissa bits, no sign, no denormals here: see packR11G11B10).
//
// Conventions: Z up, metres, linear RGB; light values Phi_k as directions.h defines them. A grid
// is `size` cells of `cell_m` metres from world corner `origin` (the min corner, double precision:
// worlds may sit far from the origin); cell (i, j, k) has its centre at
// origin + (i + 0.5, j + 0.5, k + 0.5) cell_m and index i + size.x (j + size.y k).
//
// Thread-safety: value types; const members may run from any number of threads at once.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <new>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/sweep/directions.h"

namespace drtv::sweep {

struct GridShape {
  glm::dvec3 origin{0.0};   // world metres of the min corner
  double cell_m = 1.0;      // cell edge, metres, > 0
  glm::ivec3 size{0};       // cells per axis, each >= 1

  size_t cellCount() const { return size_t(size.x) * size_t(size.y) * size_t(size.z); }
  size_t index(int i, int j, int k) const { return size_t(i) + size_t(size.x) * (size_t(j) + size_t(size.y) * size_t(k)); }
  glm::dvec3 centre(int i, int j, int k) const { return origin + (glm::dvec3(i, j, k) + 0.5) * cell_m; }
  glm::dvec3 max() const { return origin + glm::dvec3(size) * cell_m; }
  // Whether world `p` lies in the grid's box (min inclusive, max exclusive).
  bool contains(const glm::dvec3& p) const {
    const glm::dvec3 hi = max();
    return p.x >= origin.x && p.y >= origin.y && p.z >= origin.z && p.x < hi.x && p.y < hi.y && p.z < hi.z;
  }
};

// What absorbs and reflects light, one cell per light-grid cell [1].
// `density` is the seed's: 0 empty, 1 full (nothing passes, e.g. under the ground); the share of
// light that crosses one cell length unabsorbed and unreflected is 1 - density, and a path of
// l cell lengths passes (1 - density)^l. Of what does not pass, `reflectance` is reflected
// diffusely (directions.h's bins) and the rest absorbed.
struct MaterialGrid {
  GridShape shape;
  std::vector<float> density;          // per cell, [0, 1]
  std::vector<glm::vec3> reflectance;  // per cell, RGB in [0, 1]
  // Optional, per column (i + size.x j): the ground's highest point in it, world metres (empty:
  // unknown). A finer grid's edges read this grid's light no lower than the cell above it
  // (sweep.h).
  std::vector<float> ground_z;

  // An empty (all clear) grid of `shape`.
  static MaterialGrid clear(const GridShape& shape) {
    return {shape, std::vector<float>(shape.cellCount(), 0.f), std::vector<glm::vec3>(shape.cellCount(), glm::vec3(0.f)), {}};
  }
};

// R11G11B10 [2]: round to nearest, values below 2^-14 (6.1e-5) stored as 0, above 65024 clamped,
// negative and NaN as 0. Pure.
uint32_t packR11G11B10(const glm::vec3& rgb);
glm::vec3 unpackR11G11B10(uint32_t bits);

// std::allocator, except that the elements a vector adds without a value (resize(n), vector(n))
// are default-initialised: for words, left as they are. assign(n, v), resize(n, v) and every
// constructor or insert with a value still fill. The sweep writes every word of its light grid, and
// zeroing a fresh 1 m sector's 13.6 MB first was 10 % of its sweep (docs/sweep.md).
template <class T>
struct UninitialisedAllocator : std::allocator<T> {
  template <class U>
  struct rebind {
    using other = UninitialisedAllocator<U>;
  };
  UninitialisedAllocator() noexcept = default;
  template <class U>
  UninitialisedAllocator(const UninitialisedAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};
// A light grid's words (LightGrid): a vector whose resize(n) does not zero them.
using Words = std::vector<uint32_t, UninitialisedAllocator<uint32_t>>;

// A swept light grid in its stored form [1]. Per cell: the 26 light values (directions.h) halfway
// through the cell, R11G11B10; the average light (sum_k Phi_k / 4 pi: mean radiance), R11G11B10;
// the dominant direction (luminance-weighted mean source direction, length = how sharply the light
// comes from it, 1 for a single bin), as 3 signed bytes + 1 spare.
struct LightGrid {
  GridShape shape;
  Words light;      // 26 per cell, cell-major: light[26 * cell + k]
  Words average;    // per cell
  Words dominant;   // per cell, glm::packSnorm4x8(x, y, z, 0)
  // Empty, or (SweepOptions::keep_unpacked) the 26 light values per cell as the sweep had them
  // before packing, cell-major as `light`: then cell(), sample() and ambient() read these, not
  // the words. A measurement of what the stored form costs, not a stored form (12 bytes a value).
  std::vector<glm::vec3> unpacked;

  static constexpr size_t kBytesPerCell = (kDirections + 2) * sizeof(uint32_t);
  size_t bytes() const {
    return (light.size() + average.size() + dominant.size()) * sizeof(uint32_t) + unpacked.size() * sizeof(glm::vec3);
  }

  // The 26 light values of cell `index`, decoded (or unpacked's).
  LightVector cell(size_t index) const;
  // The light values at world `p`, trilinear between the 8 cell centres around it (clamped to the
  // outermost centres outside them).
  LightVector sample(const glm::dvec3& p) const;
  // Irradiance (linear RGB, the sky's units) at world `p` on unit normal `n`:
  // directions.h's E(n) of sample(p).
  glm::vec3 ambient(const glm::dvec3& p, const glm::vec3& n) const { return irradiance(sample(p), n); }
  // The average-light grid and the dominant direction at `p`, trilinear likewise.
  glm::vec3 averageLight(const glm::dvec3& p) const;
  glm::vec3 dominantDirection(const glm::dvec3& p) const;
};

}  // namespace drtv::sweep
