// The light at the sweep's edges (sweep.h, SkyInput and `parent`): the open sky, or a coarser
// grid decoded once around this one and interpolated to each level. Private to drtv::sweep.
#pragma once

#include <cstddef>
#include <vector>

#include "drtv/sweep/sweep.h"

namespace drtv::sweep::detail {

// Not thread-safe: fill keeps a scratch slice.
class Edges {
 public:
  // The edges of grid `g` under `sky`, or, with a parent (the grid one level coarser, swept, with
  // its direct light), the parent's cells around g, decoded once.
  Edges(const GridShape& g, const SkyInput& sky, const SweptGrid* parent);

  // Whether the edges' light is the same at every level (the open sky).
  bool sameAtEveryLevel() const { return parent_ == nullptr; }

  // The light of the cells (i, j) in `cells` at grid level k (may be -1 or size.z) for `bins`,
  // into planes[cell.r * row_stride + (b * 3 + c) * plane_stride + cell.x] (r, x: the cell's padded
  // row and column).
  struct Cell {
    int i, j;
    size_t r, x;
  };
  void fill(int k, bool direct, const std::vector<int>& bins, const std::vector<Cell>& cells, float* planes,
            size_t plane_stride, size_t row_stride);

 private:
  GridShape g_;
  SkyInput sky_;
  const SweptGrid* parent_;
  int i0_ = 0, j0_ = 0, ni_ = 0, nj_ = 0;
  std::vector<LightVector> full_, direct_, slice_;
};

}  // namespace drtv::sweep::detail
