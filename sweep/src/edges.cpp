// The sweep's edges (edges.h).
#include "edges.h"

#include <algorithm>
#include <cmath>

#include "drtv/formats/error.h"
#include "paths.h"

namespace drtv::sweep::detail {

Edges::Edges(const GridShape& g, const SkyInput& sky, const SweptGrid* parent) : g_(g), sky_(sky), parent_(parent) {
  if (!parent_) return;
  DRTV_CHECK(parent_->light_has_direct || parent_->direct.has_value());
  const GridShape& p = parent_->light.shape;
  const glm::dvec3 lo = g.origin - double(kPad + 1) * g.cell_m, hi = g.max() + double(kPad + 1) * g.cell_m;
  i0_ = std::clamp(int(std::floor((lo.x - p.origin.x) / p.cell_m - 0.5)), 0, p.size.x - 1);
  j0_ = std::clamp(int(std::floor((lo.y - p.origin.y) / p.cell_m - 0.5)), 0, p.size.y - 1);
  const int i1 = std::clamp(int(std::floor((hi.x - p.origin.x) / p.cell_m - 0.5)) + 1, 0, p.size.x - 1);
  const int j1 = std::clamp(int(std::floor((hi.y - p.origin.y) / p.cell_m - 0.5)) + 1, 0, p.size.y - 1);
  ni_ = i1 - i0_ + 1;
  nj_ = j1 - j0_ + 1;
  full_.resize(size_t(ni_) * nj_ * p.size.z);
  direct_.resize(full_.size());
  for (int k = 0; k < p.size.z; ++k)
    for (int j = 0; j < nj_; ++j)
      for (int i = 0; i < ni_; ++i) {
        const size_t src = p.index(i0_ + i, j0_ + j, k), dst = (size_t(k) * nj_ + j) * ni_ + i;
        LightVector d{};
        if (parent_->direct) d = parent_->direct->cell(src);
        LightVector f = parent_->light.cell(src);
        if (!parent_->light_has_direct)
          for (int b = 0; b < kDirections; ++b) f[size_t(b)] += d[size_t(b)];
        full_[dst] = f;
        direct_[dst] = d;
      }
}

void Edges::fill(int k, bool direct, const std::vector<int>& bins, const std::vector<Cell>& cells, float* planes,
                 size_t plane_stride, size_t row_stride) {
  const size_t nb = bins.size();
  if (!parent_) {
    // The same light in every cell: runs of cells along a row are filled at once (the top
    // level's fill, cell by cell, was 3 % of the sector's sweep).
    for (size_t b = 0; b < nb; ++b) {
      const int bin = bins[b];
      const glm::vec3 v = direct ? sky_.sun[size_t(bin)] : sky_.sky[size_t(bin)] + sky_.sun[size_t(bin)];
      for (size_t first = 0; first < cells.size();) {
        size_t last = first + 1;
        while (last < cells.size() && cells[last].r == cells[first].r && cells[last].x == cells[last - 1].x + 1) ++last;
        for (int c = 0; c < 3; ++c)
          std::fill_n(planes + cells[first].r * row_stride + (b * 3 + size_t(c)) * plane_stride + cells[first].x, last - first, v[c]);
        first = last;
      }
    }
    return;
  }
  const GridShape& p = parent_->light.shape;
  // The parent's columns interpolated to this level's height once, then bilinear per cell.
  const double zc = g_.origin.z + (k + 0.5) * g_.cell_m;
  const std::vector<LightVector>& src = direct ? direct_ : full_;
  slice_.resize(size_t(ni_) * nj_);
  for (size_t col = 0; col < slice_.size(); ++col) {
    const size_t pcol = size_t(i0_) + col % size_t(ni_) + size_t(p.size.x) * (size_t(j0_) + col / size_t(ni_));
    const double z = parent_->clear_z.empty() ? zc : std::max(zc, double(parent_->clear_z[pcol]));
    const double u = std::clamp((z - p.origin.z) / p.cell_m - 0.5, 0.0, double(p.size.z - 1));
    const int k0 = std::min(int(u), p.size.z - 1), k1 = std::min(k0 + 1, p.size.z - 1);
    const float fz = float(u - k0);
    for (size_t b = 0; b < nb; ++b) {
      const size_t bin = size_t(bins[b]);
      slice_[col][bin] = src[size_t(k0) * slice_.size() + col][bin] * (1 - fz) + src[size_t(k1) * slice_.size() + col][bin] * fz;
    }
  }
  for (const Cell& cell : cells) {
    const glm::dvec3 w = g_.centre(cell.i, cell.j, 0);
    const double ux = std::clamp((w.x - p.origin.x) / p.cell_m - 0.5 - i0_, 0.0, double(ni_ - 1));
    const double uy = std::clamp((w.y - p.origin.y) / p.cell_m - 0.5 - j0_, 0.0, double(nj_ - 1));
    const int a0 = std::min(int(ux), ni_ - 1), a1 = std::min(a0 + 1, ni_ - 1);
    const int b0 = std::min(int(uy), nj_ - 1), b1 = std::min(b0 + 1, nj_ - 1);
    const float fx = float(ux - a0), fy = float(uy - b0);
    const LightVector& s00 = slice_[size_t(b0) * ni_ + a0];
    const LightVector& s10 = slice_[size_t(b0) * ni_ + a1];
    const LightVector& s01 = slice_[size_t(b1) * ni_ + a0];
    const LightVector& s11 = slice_[size_t(b1) * ni_ + a1];
    for (size_t b = 0; b < nb; ++b) {
      const size_t bin = size_t(bins[b]);
      const glm::vec3 v = (s00[bin] * (1 - fx) + s10[bin] * fx) * (1 - fy) + (s01[bin] * (1 - fx) + s11[bin] * fx) * fy;
      for (int c = 0; c < 3; ++c) planes[cell.r * row_stride + (b * 3 + size_t(c)) * plane_stride + cell.x] = v[c];
    }
  }
}

}  // namespace drtv::sweep::detail
