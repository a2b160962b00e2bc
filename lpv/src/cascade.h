// The state of a CascadedLpv (lpv.h), shared by the files that make it: its cascades' grids, the
// propagation's scratch, and the constants of the layout they share. Private to drtv::lpv.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/lpv/lpv.h"

namespace drtv::lpv {
namespace detail {

inline constexpr int kPlanes = 12;  // 3 channels x 4 SH coefficients, plane p = channel * 4 + coefficient

// Propagation steps made in one sweep over the slabs (propagate): their ring buffers, 3 slabs
// each, stay in the L2 cache (8 x 3 x 4 x 34^2 floats = 444 KB at 32 cells).
inline constexpr int kWaveDepth = 8;

// The 6 propagation directions: the direction light travels from the source neighbour into the
// receiving cell. d = 2 * axis + (0: +, 1: -).
inline constexpr int kDirs = 6;
inline glm::ivec3 dirVector(int d) {
  glm::ivec3 v(0);
  v[d / 2] = (d % 2) ? -1 : 1;
  return v;
}

// One channel's 4 planes of a padded grid ((n+2)^3, a zero cell around it) and its per-slab
// row flags ((n+2) x (n+2), 0: the row holds only zeros): a sweep's last step, read by the next.
struct StepGrid {
  std::vector<float> planes;
  std::vector<uint8_t> lit;
  void allocate(int n) {
    const size_t np = size_t(n) + 2;
    if (!planes.empty()) return;
    planes.assign(4 * np * np * np, 0.f);
    lit.assign(np * np, 0);
  }
  size_t bytes() const { return planes.size() * sizeof(float) + lit.size(); }
};

}  // namespace detail

struct CascadedLpv::Cascade {
  CascadeBox box;
  int n = 0;
  size_t cells = 0;
  // kPlanes x (n+2)^3, padded by a zero cell on every side (the propagation reads it in place);
  // inj_lit: per padded slab, channel and padded row (((k+1) * 3 + ch) * (n+2) + j+1), whether
  // an injection added non-zero flux to the row (the propagation skips rows without light, and
  // clearLight clears only the flagged ones).
  std::vector<float> injected;
  std::vector<uint8_t> inj_lit;
  std::vector<float> light;        // kPlanes x cells: injected + every step
  std::vector<uint8_t> light_lit;  // per slab, channel and row ((k * 3 + ch) * n + j): may be non-zero
  std::vector<float> last_step;  // band-0 of the last step, per channel (3 x cells): tests
  std::vector<uint8_t> last_lit;  // per slab, channel and row, as light_lit: may be non-zero
  std::vector<float> geometry;   // 4 x (n+1)^3 blocking potential SH on the corners
  std::vector<float> face_t;     // kDirs x cells: transmittance of light entering through that face
  std::vector<uint8_t> sky_t;    // kSkyDirections x cells, T in 1/255
  std::vector<float> sky;        // kPlanes x cells: visible sky radiance SH
  size_t index(int i, int j, int k) const { return size_t(i) + size_t(n) * (size_t(j) + size_t(n) * size_t(k)); }
  size_t padded() const { return size_t(n + 2) * size_t(n + 2) * size_t(n + 2); }
  size_t paddedIndex(int i, int j, int k) const {
    const size_t np = size_t(n) + 2;
    return size_t(i + 1) + np * (size_t(j + 1) + np * size_t(k + 1));
  }
  size_t corner(int i, int j, int k) const {
    const size_t m = size_t(n) + 1;
    return size_t(i) + m * (size_t(j) + m * size_t(k));
  }
};

// One thread's propagation scratch (see propagate): the ring buffers of the steps of a sweep and,
// for more than kWaveDepth iterations, two padded grids that carry a sweep's last step to the next.
struct CascadedLpv::Scratch {
  std::vector<float> ring;        // kWaveDepth x 3 slots x 4 planes x (n+2)^2
  std::vector<uint8_t> ring_lit;  // kWaveDepth x 3 slots x (n+2) rows
  std::array<detail::StepGrid, 2> grids;  // allocated when needed
};

// Two threads' propagation (see propagate): per channel, the grid where the first job leaves
// the last of its steps for the second job, and how many of that grid's slabs of z are made.
struct CascadedLpv::Pipeline {
  std::array<detail::StepGrid, 3> grids;  // allocated when needed
  std::array<std::atomic<int>, 3> made{};
};

}  // namespace drtv::lpv
