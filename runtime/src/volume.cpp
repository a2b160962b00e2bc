// volume.cpp — see volume.h for the references [1-2], the layout and the defaults. The blur is
// volume_blur.cpp.
#include "drtv/runtime/volume.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <span>

#include "drtv/formats/error.h"
#include "pack.h"
#include "toroidal.h"

namespace drtv::runtime {
namespace {

// Cameras are clamped to +-1e8 m so that world texel indices fit in int32 for texels >= 0.05 m.
constexpr double kMaxCameraM = 1e8;

using detail::floorDiv;
using detail::floorMod;

// Boxes at most this many texels wide in x are filled column by column (see fillBox).
constexpr int kThinSlabX = 2;

// floor() inline: on the x86-64 baseline std::floor is a libm call (no SSE4.1 roundsd), and a
// one-texel scroll computes ~250 of them (a third of its time). |v| < 2^31 (cameras are clamped).
inline int floorInt(double v) {
  const int t = int(v);  // truncates toward zero
  return t - int(double(t) > v);
}
// The index-grid cell of a coordinate in cell units, clamped to the grid (NaN reads as 0).
inline int cellOf(double v) { return v > 0.0 ? int(std::min(v, double(kGridDim - 1))) : 0; }

// Sector slots of a rectangle of sector keys, looked up once per fill.
struct SlotTable {
  int ix0 = 0, iy0 = 0, w = 0, h = 0;
  std::vector<ProbeCache::SlotView> views;
  std::vector<uint8_t> present;
  SlotTable(const ProbeCache& cache, int ix0_, int ix1, int iy0_, int iy1) : ix0(ix0_), iy0(iy0_), w(ix1 - ix0_ + 1), h(iy1 - iy0_ + 1) {
    views.resize(size_t(w) * h);
    present.assign(size_t(w) * h, 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int s = cache.slotOf({ix0 + x, iy0 + y});
        if (s < 0) continue;
        views[size_t(y) * w + x] = cache.slot(s);
        present[size_t(y) * w + x] = views[size_t(y) * w + x].probe_count > 0;
      }
  }
  const ProbeCache::SlotView* at(int ix, int iy) const {
    const size_t i = size_t(iy - iy0) * w + (ix - ix0);
    return present[i] ? &views[i] : nullptr;
  }
};

// Each present slot's index-grid layer for texel layers [z0, z0 + dz) of `texel_z` metres:
// cz[z * slots + t] (0 for absent slots). Computed once per box: a thin slab has many rows of one
// texel, and per-row float work would dominate.
void layerCells(const SlotTable& table, int z0, int dz, double texel_z, std::vector<int>& cz) {
  const int table_size = table.w * table.h;
  cz.assign(size_t(dz) * table_size, 0);
  for (int z = 0; z < dz; ++z) {
    const double zc = (z0 + z + 0.5) * texel_z;
    for (int t = 0; t < table_size; ++t)
      if (table.present[t])
        cz[size_t(z) * table_size + t] = cellOf((zc - table.views[t].grid_z_min_m) / table.views[t].grid_cell_height_m);
  }
}

}  // namespace

Volume::Volume(const VolumeOptions& options) : options_(options) {
  DRTV_CHECK(options.size.x >= 3 && options.size.y >= 3 && options.size.z >= 3);
  for (int a = 0; a < 3; ++a) DRTV_CHECK(std::isfinite(options.texel_size_m[a]) && options.texel_size_m[a] > 0.f);
  const size_t n = size_t(options.size.x) * options.size.y * options.size.z;
  for (auto& t : texels_) t.assign(n, 0);
  if (!options.blur) return;
  const float half_cell = float(kGridCellSizeM / 2.0);
  cell_source_ = options.fill == FillMode::kNearest && options.texel_size_m.x == half_cell && options.texel_size_m.y == half_cell;
  const glm::ivec3 p = period();
  if (cell_source_) {
    // Rows of whole vectors of cells (8: 32 16-bit lanes): the blur's passes over rows of cells
    // then leave no scalar remainder.
    cell_period_ = glm::ivec2((p.x / 2 + 2 + 7) / 8 * 8, p.y / 2 + 2);
    source_stride_ = {1, cell_period_.x, cell_period_.x * cell_period_.y};
  } else {
    source_stride_ = {1, options.size.x, options.size.x * options.size.y};
  }
  const size_t source_n = cell_source_ ? size_t(source_stride_.z) * size_t(p.z) : n;
  for (auto& t : source_) t.assign(source_n, 0);
}

size_t Volume::sourceOffset(int a, int g) const {
  const int i = a < 2 && cell_source_ ? floorMod(floorDiv(g, 2), cell_period_[a]) : floorMod(g, period()[a]);
  return size_t(i) * size_t(source_stride_[a]);
}

void Volume::sourceOffsets(const glm::ivec3& a0, const glm::ivec3& a, std::vector<size_t>& xs, std::vector<size_t>& ys,
                           std::vector<size_t>& zs) const {
  std::vector<size_t>* v[3] = {&xs, &ys, &zs};
  for (int k = 0; k < 3; ++k) {
    v[k]->resize(size_t(a[k]));
    for (int i = 0; i < a[k]; ++i) (*v[k])[size_t(i)] = sourceOffset(k, a0[k] + i);
  }
}

glm::ivec3 volumeOriginFor(const VolumeOptions& options, const glm::dvec3& camera) {
  glm::ivec3 o;
  for (int a = 0; a < 3; ++a) {
    const double c = std::isfinite(camera[a]) ? std::clamp(camera[a], -kMaxCameraM, kMaxCameraM) : 0.0;
    o[a] = int(std::floor(c / options.texel_size_m[a])) - (options.size[a] - 1) / 2;
  }
  return o;
}

uint32_t Volume::physicalTexel(int channel, const glm::ivec3& p) const { return texels_.at(channel).at(physicalIndex(p)); }

uint32_t Volume::worldTexel(int channel, const glm::ivec3& g) const {
  const glm::ivec3 n = period();
  for (int a = 0; a < 3; ++a) DRTV_CHECK(g[a] >= origin_[a] && g[a] < origin_[a] + n[a]);
  return texels_[channel][physicalIndex({floorMod(g.x, n.x), floorMod(g.y, n.y), floorMod(g.z, n.z)})];
}

// On a 64-byte boundary: where the code before it left it 16 bytes past one, its loops sat across
// other fetch windows and a nearest refill took 1.25x as long (BM_FullRefillNearest, 190 vs 240 us).
[[gnu::aligned(64)]] void Volume::fillBox(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache) {
  const glm::ivec3 n = period();
  const glm::ivec3 d = g1 - g0;
  if (d.x <= 0 || d.y <= 0 || d.z <= 0) return;
  auto& dst = options_.blur ? source_ : texels_;
  struct Axis {
    int sector, cell, s;
  };
  // Per column and row: the sector, the index-grid cell and the storage index of each texel.
  // Scratch is per thread and kept (a one-texel scroll is ~3 us; allocations were a tenth of it).
  thread_local std::vector<Axis> xs, ys;
  auto axis = [&](int a, int count, std::vector<Axis>& v) {
    v.resize(size_t(count));
    for (int i = 0; i < count; ++i) {
      const int g = g0[a] + i;
      const double c = (g + 0.5) * double(options_.texel_size_m[a]);
      const int sec = floorInt(c / kSectorSizeM);
      v[size_t(i)] = {sec, cellOf((c - sec * kSectorSizeM) / kGridCellSizeM), floorMod(g, n[a])};
    }
  };
  axis(0, d.x, xs);
  axis(1, d.y, ys);
  // The box's storage indices per axis, for the duplicated boundary (mirrorBoundary).
  thread_local std::vector<int> sxs, sys, szs;
  sxs.resize(size_t(d.x)), sys.resize(size_t(d.y)), szs.resize(size_t(d.z));
  for (int i = 0; i < d.x; ++i) sxs[size_t(i)] = xs[size_t(i)].s;
  for (int i = 0; i < d.y; ++i) sys[size_t(i)] = ys[size_t(i)].s;
  for (int i = 0; i < d.z; ++i) szs[size_t(i)] = floorMod(g0.z + i, n.z);
  const SlotTable table(cache, xs.front().sector, xs.back().sector, ys.front().sector, ys.back().sector);
  const std::array<uint32_t, 3> fb = cache.packedFallback();
  const int table_size = table.w * table.h;
  thread_local std::vector<int> cz;
  layerCells(table, g0.z, d.z, double(options_.texel_size_m.z), cz);
  if (d.x <= kThinSlabX) {
    // A slab this thin in x (a scroll along x) has one or two texels per row: the row loop below
    // would pay its per-row set-up (row pointers, sector runs, boundary checks) for each of them
    // (10 us for a one-texel x scroll, against 2 us for its stores alone). Go column by column
    // with the per-row data of y computed once; the stores stay scattered (x-major rows).
    const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
    struct YRow {
      int cell;       // the index-grid row, times 16
      size_t offset;  // storage row offset
    };
    struct YRun {
      int t, begin, end;  // the sector's row in the slot table; rows [begin, end) of yrows
    };
    thread_local std::vector<YRow> yrows;
    thread_local std::vector<YRun> yruns;
    yrows.resize(size_t(d.y));
    yruns.clear();
    for (int i = 0; i < d.y; ++i) {
      const Axis& ya = ys[size_t(i)];
      yrows[size_t(i)] = {ya.cell * kGridDim, size_t(ya.s) * row_stride};
      const int t = (ya.sector - table.iy0) * table.w;
      if (yruns.empty() || yruns.back().t != t) yruns.push_back({t, i, i});
      yruns.back().end = i + 1;
    }
    for (const Axis& xa : xs) {
      const int tx = xa.sector - table.ix0;
      for (int z = 0; z < d.z; ++z) {
        const size_t layer = size_t(floorMod(g0.z + z, n.z)) * layer_stride + size_t(xa.s);
        uint32_t* __restrict c0 = dst[0].data() + layer;
        uint32_t* __restrict c1 = dst[1].data() + layer;
        uint32_t* __restrict c2 = dst[2].data() + layer;
        const int* cz_row = cz.data() + size_t(z) * table_size;
        for (const YRun& run : yruns) {
          const int t = run.t + tx;
          const YRow* __restrict rows = yrows.data();
          if (!table.present[size_t(t)]) {
            for (int i = run.begin; i < run.end; ++i) {
              c0[rows[i].offset] = fb[0];
              c1[rows[i].offset] = fb[1];
              c2[rows[i].offset] = fb[2];
            }
            continue;
          }
          const ProbeCache::SlotView& v = table.views[size_t(t)];
          // This column of the sector's index grid at this layer: one byte per grid row.
          const uint8_t* __restrict column = v.nearest + cz_row[t] * (kGridDim * kGridDim) + xa.cell;
          const uint32_t* __restrict packed = v.packed;
          for (int i = run.begin; i < run.end; ++i) {
            const uint32_t* src = packed + 3 * column[rows[i].cell];
            c0[rows[i].offset] = src[0];
            c1[rows[i].offset] = src[1];
            c2[rows[i].offset] = src[2];
          }
        }
      }
    }
    for (int c = 0; c < 3; ++c) mirrorBoundary(dst[c].data(), sxs, sys, szs);
    filled_ += uint64_t(d.x) * d.y * d.z;
    return;
  }
  // The box's columns in runs of one sector, and each run in pieces: chains of texel pairs, a pair
  // being one index cell's two texels in consecutive storage columns (the talk's 2 m texels in
  // 4 m cells) and a chain pairs of consecutive cells over consecutive storage; or a single texel
  // (a cell split by an odd origin, the toroidal wrap or the run's end). Per pair, one index read
  // and one 8-byte store per texture. Found per box, not per row: the search for each row's sector
  // runs and one index read and three 4-byte stores per texel were a third of a full refill (perf).
  struct XPiece {
    int s, cell, pairs;  // storage column and index cell of the first texel; 0 pairs: one texel
  };
  struct XRun {
    int t, begin, end;  // the sector's column in the slot table; pieces [begin, end)
    int first, last;    // its columns in xs
  };
  thread_local std::vector<XPiece> pieces;
  thread_local std::vector<XRun> xruns;
  pieces.clear();
  xruns.clear();
  for (int i = 0; i < d.x;) {
    const int sec = xs[size_t(i)].sector;
    int j = i;
    while (j < d.x && xs[size_t(j)].sector == sec) ++j;
    XRun run{sec - table.ix0, int(pieces.size()), 0, i, j};
    for (int k = i; k < j;) {
      const Axis& xa = xs[size_t(k)];
      const bool pair = k + 1 < j && xs[size_t(k + 1)].cell == xa.cell && xs[size_t(k + 1)].s == xa.s + 1;
      if (!pair) {
        pieces.push_back({xa.s, xa.cell, 0});
      } else if (pieces.size() > size_t(run.begin) && pieces.back().pairs > 0 &&
                 pieces.back().s + 2 * pieces.back().pairs == xa.s && pieces.back().cell + pieces.back().pairs == xa.cell) {
        ++pieces.back().pairs;
      } else {
        pieces.push_back({xa.s, xa.cell, 1});
      }
      k += pair ? 2 : 1;
    }
    run.end = int(pieces.size());
    xruns.push_back(run);
    i = j;
  }
  // A box of whole rows copies a row whose index cells (its y cell, in the same sector) are the
  // row before's: a 4 m cell's second row of 2 m texels. Half the rows of a refill are then one
  // copy each instead of a lookup per pair.
  const bool whole_rows = d.x == n.x;
  for (int z = g0.z; z < g1.z; ++z) {
    const int sz = floorMod(z, n.z);
    const int* cz_row = cz.data() + size_t(z - g0.z) * table_size;
    for (const Axis& ya : ys) {
      uint32_t* __restrict r0 = dst[0].data() + physicalIndex({0, ya.s, sz});
      uint32_t* __restrict r1 = dst[1].data() + physicalIndex({0, ya.s, sz});
      uint32_t* __restrict r2 = dst[2].data() + physicalIndex({0, ya.s, sz});
      if (whole_rows && &ya != ys.data() && (&ya - 1)->sector == ya.sector && (&ya - 1)->cell == ya.cell) {
        const size_t from = physicalIndex({0, (&ya - 1)->s, sz}), bytes = size_t(n.x) * sizeof(uint32_t);
        std::memcpy(r0, dst[0].data() + from, bytes), std::memcpy(r1, dst[1].data() + from, bytes);
        std::memcpy(r2, dst[2].data() + from, bytes);
        continue;
      }
      const int ty = (ya.sector - table.iy0) * table.w;
      for (const XRun& run : xruns) {
        const int t = ty + run.t;
        if (!table.present[size_t(t)]) {
          for (int k = run.first; k < run.last; ++k) {
            const int sx = xs[size_t(k)].s;
            r0[sx] = fb[0], r1[sx] = fb[1], r2[sx] = fb[2];
          }
          continue;
        }
        const ProbeCache::SlotView& v = table.views[size_t(t)];
        const uint8_t* __restrict cells = v.nearest + (cz_row[t] * kGridDim + ya.cell) * kGridDim;
        const uint32_t* __restrict packed = v.packed;
        for (const XPiece* p = pieces.data() + run.begin, *p_end = pieces.data() + run.end; p != p_end; ++p) {
          const uint8_t* __restrict cc = cells + p->cell;
          if (p->pairs == 0) {
            const uint32_t* tx = packed + 3 * cc[0];
            r0[p->s] = tx[0], r1[p->s] = tx[1], r2[p->s] = tx[2];
            continue;
          }
          uint32_t* __restrict o0 = r0 + p->s;
          uint32_t* __restrict o1 = r1 + p->s;
          uint32_t* __restrict o2 = r2 + p->s;
          for (int g = 0, m = p->pairs; g < m; ++g) {
            const uint32_t* tx = packed + 3 * cc[g];
            const uint64_t w0 = tx[0] * 0x100000001ull, w1 = tx[1] * 0x100000001ull, w2 = tx[2] * 0x100000001ull;
            std::memcpy(o0 + 2 * g, &w0, 8), std::memcpy(o1 + 2 * g, &w1, 8), std::memcpy(o2 + 2 * g, &w2, 8);
          }
        }
      }
    }
  }
  for (int c = 0; c < 3; ++c) mirrorBoundary(dst[c].data(), sxs, sys, szs);
  filled_ += uint64_t(d.x) * d.y * d.z;
}

// The cells are those of fillBox's texels: a texel 2 m across at world column g has its centre
// at 4 m * g / 2 + 1 or 3 m, in index cell floor(g / 2) (sector boundaries, every 16 cells, are
// cell boundaries). A cell only partly inside the box is written whole: its other texel takes the
// probe it already had, or, if the cache changed since, the current one.
void Volume::fillCells(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache) {
  const glm::ivec3 d = g1 - g0;
  if (d.x <= 0 || d.y <= 0 || d.z <= 0) return;
  struct Axis {
    int sector, cell;
    size_t offset;  // in source_
  };
  thread_local std::vector<Axis> xs, ys;
  auto axis = [&](int a, std::vector<Axis>& v) {
    const int c0 = floorDiv(g0[a], 2), c1 = floorDiv(g1[a] - 1, 2) + 1;
    v.resize(size_t(c1 - c0));
    for (int c = c0; c < c1; ++c) {
      const int sec = floorDiv(c, kGridDim);
      v[size_t(c - c0)] = {sec, c - sec * kGridDim, size_t(floorMod(c, cell_period_[a])) * size_t(source_stride_[a])};
    }
  };
  axis(0, xs);
  axis(1, ys);
  const SlotTable table(cache, xs.front().sector, xs.back().sector, ys.front().sector, ys.back().sector);
  const std::array<uint32_t, 3> fb = cache.packedFallback();
  const int table_size = table.w * table.h;
  thread_local std::vector<int> cz;
  layerCells(table, g0.z, d.z, double(options_.texel_size_m.z), cz);
  uint32_t* __restrict c0 = source_[0].data();
  uint32_t* __restrict c1 = source_[1].data();
  uint32_t* __restrict c2 = source_[2].data();
  // The columns in runs of one sector and consecutive storage (found once per box): per run, one
  // row of index bytes read in order and three rows of cells written in order.
  struct XRun {
    int t, cell, len;  // the sector's column in the slot table; its first index cell; cells
    size_t offset;     // in source_, of the first cell
  };
  thread_local std::vector<XRun> xruns;
  xruns.clear();
  for (size_t i = 0; i < xs.size(); ++i) {
    const Axis& xa = xs[i];
    if (i > 0 && xa.sector == xs[i - 1].sector && xa.offset == xs[i - 1].offset + 1)
      ++xruns.back().len;
    else
      xruns.push_back({xa.sector - table.ix0, xa.cell, 1, xa.offset});
  }
  for (int z = 0; z < d.z; ++z) {
    const size_t layer = size_t(floorMod(g0.z + z, period().z)) * size_t(source_stride_.z);
    const int* cz_row = cz.data() + size_t(z) * table_size;
    for (const Axis& ya : ys) {
      const int ty = (ya.sector - table.iy0) * table.w;
      const size_t row = layer + ya.offset;
      // The next row's lines, for writing: they were last written a refill ago, and the textures
      // written since have evicted them.
      if (&ya != &ys.back())
        for (size_t b = 0; b < size_t(source_stride_.y); b += 16) {
          const size_t next = layer + (&ya + 1)->offset + b;
          __builtin_prefetch(c0 + next, 1), __builtin_prefetch(c1 + next, 1), __builtin_prefetch(c2 + next, 1);
        }
      for (const XRun& run : xruns) {
        const int t = ty + run.t, len = run.len;
        uint32_t* __restrict o0 = c0 + row + run.offset;
        uint32_t* __restrict o1 = c1 + row + run.offset;
        uint32_t* __restrict o2 = c2 + row + run.offset;
        if (!table.present[size_t(t)]) {
          for (int k = 0; k < len; ++k) o0[k] = fb[0], o1[k] = fb[1], o2[k] = fb[2];
          continue;
        }
        const ProbeCache::SlotView& v = table.views[size_t(t)];
        const uint8_t* __restrict cells = v.nearest + (cz_row[t] * kGridDim + ya.cell) * kGridDim + run.cell;
        const uint32_t* __restrict packed = v.packed;
        for (int k = 0; k < len; ++k) {
          const uint32_t* tx = packed + 3 * cells[k];
          o0[k] = tx[0], o1[k] = tx[1], o2[k] = tx[2];
        }
      }
    }
  }
  filled_ += uint64_t(d.x) * d.y * d.z;
}

void Volume::fillBoxSmooth(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache) {
  const glm::ivec3 n = period();
  const glm::ivec3 d = g1 - g0;
  if (d.x <= 0 || d.y <= 0 || d.z <= 0) return;
  auto& dst = options_.blur ? source_ : texels_;
  // Trilinear weights over index-grid cell centres; the two cells of an axis may lie in two
  // sectors (cells are global: sector = floor(cell / 16)).
  struct Axis {
    int sector[2], cell[2];
    float f;
    int s;
  };
  auto axis = [&](int a, int count) {
    std::vector<Axis> v(count);
    for (int i = 0; i < count; ++i) {
      const int g = g0[a] + i;
      const double u = (g + 0.5) * double(options_.texel_size_m[a]) / kGridCellSizeM - 0.5;
      const double c0 = std::floor(u);
      v[i].f = float(u - c0);
      for (int k = 0; k < 2; ++k) {
        const int c = int(c0) + k;
        v[i].sector[k] = floorDiv(c, kGridDim);
        v[i].cell[k] = c - v[i].sector[k] * kGridDim;
      }
      v[i].s = floorMod(g, n[a]);
    }
    return v;
  };
  const std::vector<Axis> xs = axis(0, d.x), ys = axis(1, d.y);
  const SlotTable table(cache, xs.front().sector[0], xs.back().sector[1], ys.front().sector[0], ys.back().sector[1]);
  const BasisColours& fb = cache.fallback();
  const float inv = 1.f / cache.packedScale();
  for (int z = g0.z; z < g1.z; ++z) {
    const int sz = floorMod(z, n.z);
    const double zc = (z + 0.5) * double(options_.texel_size_m.z);
    for (const Axis& ya : ys)
      for (const Axis& xa : xs) {
        float acc[12] = {};
        for (int ky = 0; ky < 2; ++ky)
          for (int kx = 0; kx < 2; ++kx) {
            const float wxy = (kx ? xa.f : 1.f - xa.f) * (ky ? ya.f : 1.f - ya.f);
            if (wxy == 0.f) continue;
            const ProbeCache::SlotView* v = table.at(xa.sector[kx], ya.sector[ky]);
            if (!v) {
              for (int c = 0; c < 3; ++c)
                for (int b = 0; b < 4; ++b) acc[c * 4 + b] += wxy * fb[b][c];
              continue;
            }
            const double w = (zc - v->grid_z_min_m) / v->grid_cell_height_m - 0.5;
            const double z0 = std::floor(std::clamp(w, -1.0, double(kGridDim)));
            const float fz = float(std::clamp(w - z0, 0.0, 1.0));
            for (int kz = 0; kz < 2; ++kz) {
              const float wt = wxy * (kz ? fz : 1.f - fz);
              if (wt == 0.f) continue;
              const int cz = std::clamp(int(z0) + kz, 0, kGridDim - 1);
              const int probe = v->nearest[IndexGrid::cellIndex(xa.cell[kx], ya.cell[ky], cz)];
              for (int k = 0; k < kColourPlanes; ++k) acc[k] += wt * v->colour[k * v->colour_stride + probe];
            }
          }
        for (int c = 0; c < 3; ++c) {
          const uint32_t t = detail::packTexel(options_.representation, acc[c * 4 + 0], acc[c * 4 + 1], acc[c * 4 + 2], acc[c * 4 + 3], inv);
          for (int dz = 0; dz < (sz == 0 ? 2 : 1); ++dz)
            for (int dy = 0; dy < (ya.s == 0 ? 2 : 1); ++dy)
              for (int dx = 0; dx < (xa.s == 0 ? 2 : 1); ++dx)
                dst[c][physicalIndex({dx ? n.x : xa.s, dy ? n.y : ya.s, dz ? n.z : sz})] = t;
        }
      }
  }
  filled_ += uint64_t(d.x) * d.y * d.z;
}


void Volume::mirrorBoundary(uint32_t* tex, std::span<const int> xs, std::span<const int> ys, std::span<const int> zs) const {
  const glm::ivec3 n = period();
  const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
  auto has0 = [](std::span<const int> v) { return std::find(v.begin(), v.end(), 0) != v.end(); };
  const bool x0 = has0(xs), y0 = has0(ys), z0 = has0(zs);
  auto row = [&](int sy, int sz) { return tex + size_t(sz) * layer_stride + size_t(sy) * row_stride; };
  if (x0)
    for (const int sz : zs)
      for (const int sy : ys) {
        uint32_t* r = row(sy, sz);
        r[n.x] = r[0];
      }
  // A box of whole rows (every rebuild) copies each row at once, duplicated column included.
  const bool whole_rows = int(xs.size()) == n.x;
  auto mirror = [&](const uint32_t* from, uint32_t* to) {
    if (whole_rows) return (void)std::memcpy(to, from, (size_t(n.x) + 1) * sizeof(uint32_t));
    for (const int sx : xs) to[sx] = from[sx];
    if (x0) to[n.x] = from[n.x];
  };
  if (y0)
    for (const int sz : zs) mirror(row(0, sz), row(n.y, sz));
  if (z0)
    for (const int sy : ys) mirror(row(sy, 0), row(sy, n.z));
  if (y0 && z0) mirror(row(0, 0), row(n.y, n.z));
}

void Volume::writeRangeBox(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache) {
  DRTV_CHECK(cache.representation() == options_.representation);  // Runtime sets both from one field
  if (options_.fill == FillMode::kSmooth)
    fillBoxSmooth(g0, g1, cache);
  else if (cell_source_)
    fillCells(g0, g1, cache);
  else
    fillBox(g0, g1, cache);
}

void Volume::rebuild(const glm::ivec3& origin, const ProbeCache& cache) { beginRebuild(origin, cache, period().z); }

void Volume::beginRebuild(const glm::ivec3& origin, const ProbeCache& cache, int blur_layers) {
  origin_ = origin;
  scale_ = cache.packedScale();
  built_ = false;
  blurred_layers_ = 0;
  writeRangeBox(origin, origin + period(), cache);
  if (!options_.blur) {
    built_ = true;
    return;
  }
  advanceRebuild(blur_layers);
}

void Volume::advanceRebuild(int blur_layers) {
  DRTV_CHECK(!built_);
  const glm::ivec3 n = period();
  // A box of whole layers blurs to the same bytes as the whole volume does: its apron reads the
  // unblurred neighbours, every one of which beginRebuild filled.
  const int z1 = std::min(n.z, blurred_layers_ + std::max(0, blur_layers));
  if (z1 > blurred_layers_) blurBox(origin_ + glm::ivec3(0, 0, blurred_layers_), glm::ivec3(origin_.x + n.x, origin_.y + n.y, origin_.z + z1));
  blurred_layers_ = z1;
  built_ = blurred_layers_ == n.z;
}

void Volume::scrollTo(const glm::ivec3& origin, const ProbeCache& cache) {
  const glm::ivec3 n = period();
  const glm::ivec3 d = origin - origin_;
  if (!built_ || scale_ != cache.packedScale() || std::abs(d.x) >= n.x || std::abs(d.y) >= n.y || std::abs(d.z) >= n.z)
    return rebuild(origin, cache);
  if (d == glm::ivec3(0)) return;
  const glm::ivec3 o1 = origin_, o2 = origin;
  origin_ = origin;
  // Texels in the new range but not the old: for the first axis a on which a texel is outside
  // the old range, it lies in the entered slab of a; on earlier axes it is in both ranges, on
  // later axes anywhere in the new range. Each entered texel is filled exactly once.
  std::array<std::pair<glm::ivec3, glm::ivec3>, 3> box_list;  // at most one per axis
  size_t count = 0;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) continue;
    glm::ivec3 lo = o2, hi = o2 + n;
    for (int e = 0; e < a; ++e) lo[e] = std::max(o1[e], o2[e]), hi[e] = std::min(o1[e], o2[e]) + n[e];
    if (d[a] > 0)
      lo[a] = o1[a] + n[a], hi[a] = o2[a] + n[a];
    else
      lo[a] = o2[a], hi[a] = o1[a];
    box_list[count++] = {lo, hi};
  }
  const std::span boxes(box_list.data(), count);
  for (const auto& [lo, hi] : boxes) writeRangeBox(lo, hi, cache);
  if (!options_.blur) return;
  // Blurred texels that changed: those within one texel of an entered one, and the new faces
  // whose outer neighbour left (they now repeat themselves at the edge).
  for (const auto& [lo, hi] : boxes) blurBox(lo - 1, hi + 1);
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) continue;
    glm::ivec3 lo = o2, hi = o2 + n;
    lo[a] = d[a] > 0 ? o2[a] : o2[a] + n[a] - 1;
    hi[a] = lo[a] + 1;
    blurBox(lo, hi);
  }
}

void Volume::refillSector(SectorKey key, const ProbeCache& cache) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const glm::dvec3 lo(key.ix * kSectorSizeM, key.iy * kSectorSizeM, -kInf);
  refillBox(lo, glm::dvec3(lo.x + kSectorSizeM, lo.y + kSectorSizeM, kInf), cache);
}

bool Volume::refillRange(const glm::dvec3& box_lo, const glm::dvec3& box_hi, glm::ivec3& lo, glm::ivec3& hi) const {
  const glm::ivec3 n = period();
  lo = origin_, hi = origin_ + n;
  // The smooth fill reaches one index cell (4 m) into the neighbours: widen by that much, and in
  // z (cells of each sector's own height) take the whole column.
  const bool smooth = options_.fill == FillMode::kSmooth;
  auto clampIdx = [](double v) { return int(std::clamp(v, -2e9, 2e9)); };  // also +-inf
  for (int a = 0; a < (smooth ? 2 : 3); ++a) {
    const double margin = smooth ? kGridCellSizeM : 0.0;
    lo[a] = std::max(lo[a], clampIdx(std::floor((box_lo[a] - margin) / options_.texel_size_m[a])) - 1);
    hi[a] = std::min(hi[a], clampIdx(std::floor((box_hi[a] + margin) / options_.texel_size_m[a])) + 2);
  }
  return lo.x < hi.x && lo.y < hi.y && lo.z < hi.z;
}

uint64_t Volume::refillTexels(const glm::dvec3& box_lo, const glm::dvec3& box_hi) const {
  glm::ivec3 lo, hi;
  if (!built_ || !refillRange(box_lo, box_hi, lo, hi)) return 0;
  const glm::ivec3 d = hi - lo;
  return uint64_t(d.x) * uint64_t(d.y) * uint64_t(d.z);
}

void Volume::refillBox(const glm::dvec3& box_lo, const glm::dvec3& box_hi, const ProbeCache& cache) {
  glm::ivec3 lo, hi;
  if (!built_ || !refillRange(box_lo, box_hi, lo, hi)) return;
  if (scale_ != cache.packedScale()) return rebuild(origin_, cache);
  writeRangeBox(lo, hi, cache);
  if (options_.blur) blurBox(lo - 1, hi + 1);
}

VolumeShaderConstants Volume::shaderConstants() const {
  VolumeShaderConstants k;
  const glm::dvec3 n(period()), p(size()), ts(options_.texel_size_m), o(origin_);
  k.snapped_camera = (o + 0.5 * n) * ts;
  k.uv_scale = glm::vec3(1.0 / (n * ts));
  const glm::dvec3 w = (o - 0.5) / n;
  k.wrap_offset = glm::vec3(w - glm::floor(w));
  k.uv_remap_scale = glm::vec3(n / p);
  k.uv_remap_bias = glm::vec3(0.5 / p);
  k.hdr_scale = scale_;
  return k;
}

float Volume::coverage(const glm::dvec3& position, float fade_texels) const {
  if (!built_) return 0.f;
  float w = 1.f;
  for (int a = 0; a < 3; ++a) {
    const double t = position[a] / options_.texel_size_m[a] - origin_[a];
    const double dist = std::min(t - 0.5, period()[a] - 0.5 - t);
    if (!(dist >= 0.0)) return 0.f;  // also NaN
    if (fade_texels > 0.f) w = std::min(w, float(std::min(1.0, dist / fade_texels)));
  }
  return w;
}

namespace {
// tex3D with trilinear filtering and clamp addressing, normalised bytes (0..1).
glm::vec4 tex3D(const Volume& v, int channel, const glm::vec3& uv) {
  const glm::ivec3 p = v.size();
  int i0[3], i1[3];
  float t[3];
  for (int a = 0; a < 3; ++a) {
    const float x = uv[a] * float(p[a]) - 0.5f;
    const float f = std::floor(x);
    t[a] = x - f;
    const int i = int(std::clamp(f, -1.f, float(p[a])));
    i0[a] = std::clamp(i, 0, p[a] - 1);
    i1[a] = std::clamp(i + 1, 0, p[a] - 1);
  }
  auto fetch = [&](int x, int y, int z) {
    const uint32_t q = v.physicalTexel(channel, {x, y, z});
    return glm::vec4(float(q & 0xff), float(q >> 8 & 0xff), float(q >> 16 & 0xff), float(q >> 24)) * (1.f / 255.f);
  };
  const glm::vec4 c00 = glm::mix(fetch(i0[0], i0[1], i0[2]), fetch(i1[0], i0[1], i0[2]), t[0]);
  const glm::vec4 c10 = glm::mix(fetch(i0[0], i1[1], i0[2]), fetch(i1[0], i1[1], i0[2]), t[0]);
  const glm::vec4 c01 = glm::mix(fetch(i0[0], i0[1], i1[2]), fetch(i1[0], i0[1], i1[2]), t[0]);
  const glm::vec4 c11 = glm::mix(fetch(i0[0], i1[1], i1[2]), fetch(i1[0], i1[1], i1[2]), t[0]);
  return glm::mix(glm::mix(c00, c10, t[1]), glm::mix(c01, c11, t[1]), t[2]);
}

// A fetch's normalised bytes (byte / 255, filtered or not: the decoding is linear) as the values
// they encode: sh-l1's bytes 1..3 are offset binary (representation.h), (byte - 128) / 127; then
// times the HDR scale.
glm::vec4 decodeFetched(const Volume& v, glm::vec4 x) {
  if (v.options().representation == Representation::kShL1)
    for (int i = 1; i < 4; ++i) x[i] = (x[i] * 255.f - 128.f) * (1.f / 127.f);
  return x * v.hdrScale();
}

// The shader from `ws` (position relative to SnappedCamera, offset applied) to the three fetches.
std::array<glm::vec4, 3> fetchAt(const Volume& v, const VolumeShaderConstants& k, const glm::vec3& ws) {
  const glm::vec3 uv = glm::fract(ws * k.uv_scale + 0.5f + k.wrap_offset) * k.uv_remap_scale + k.uv_remap_bias;  // A3
  std::array<glm::vec4, 3> f = {tex3D(v, 0, uv), tex3D(v, 1, uv), tex3D(v, 2, uv)};
  for (glm::vec4& x : f) x = decodeFetched(v, x);  // A4
  return f;
}

// Ambient from the three decoded fetches: sh-l1's E(n) (S5-S6) or fc3's weights (A5-A9).
glm::vec3 shadeFetched(const Volume& volume, const std::array<glm::vec4, 3>& f, const glm::vec3& normal) {
  if (volume.options().representation == Representation::kShL1) {
    // S5-S6: E(n) = max(0, e0 + e1 n.y + e2 n.z + e3 n.x) per channel.
    const glm::vec4 y(1.f, normal.y, normal.z, normal.x);                          // S5
    return glm::max(glm::vec3(glm::dot(y, f[0]), glm::dot(y, f[1]), glm::dot(y, f[2])), glm::vec3(0.f));  // S6
  }
  const glm::vec4 w = sh::shadingWeights(normal);                                  // A5-A7
  return {glm::dot(w, f[0]), glm::dot(w, f[1]), glm::dot(w, f[2])};                // A8, A9
}
}  // namespace

glm::vec3 sampleVolume(const Volume& volume, const glm::dvec3& position, const glm::vec3& normal, float normal_offset_m) {
  const VolumeShaderConstants k = volume.shaderConstants();
  // The numbered lines correspond one to one with runtime/shaders/ambient.{glsl,hlsl}.
  const glm::vec3 sampling_offset = normal * normal_offset_m;                      // A1
  const glm::vec3 ws = glm::vec3(position - k.snapped_camera) + sampling_offset;   // A2
  return shadeFetched(volume, fetchAt(volume, k, ws), normal);                     // A3-A9, S5-S6
}

namespace {
// The trilinear filter over the 8 texels around the offset sample, the texels whose centre
// `keep(centre)` refuses given no weight and the rest sharing the filter's; all 8 refused: the plain
// filter. Eight fetches per channel.
template <class Keep>
glm::vec3 sampleKept(const Volume& volume, const glm::dvec3& position, const glm::vec3& normal, float normal_offset_m, Keep&& keep) {
  const glm::dvec3 ts(volume.options().texel_size_m);
  const glm::ivec3 lo = volume.origin(), hi = volume.origin() + volume.period() - 1;
  // World texel coordinates of the offset sample, texel centres at integers.
  const glm::dvec3 t = (position + glm::dvec3(normal) * double(normal_offset_m)) / ts - 0.5;
  const glm::dvec3 g0 = glm::floor(t), f = t - g0;
  std::array<double, 8> w{}, kept{};
  std::array<glm::ivec3, 8> g{};
  double sum_kept = 0.0;
  for (int c = 0; c < 8; ++c) {
    const glm::dvec3 corner = g0 + glm::dvec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    w[size_t(c)] = (c & 1 ? f.x : 1 - f.x) * (c & 2 ? f.y : 1 - f.y) * (c & 4 ? f.z : 1 - f.z);
    // Clamped into the covered range, as the texture's clamp addressing does at its edges.
    for (int a = 0; a < 3; ++a) g[size_t(c)][a] = int(std::clamp(corner[a], double(lo[a]), double(hi[a])));
    const glm::dvec3 centre = (glm::dvec3(g[size_t(c)]) + 0.5) * ts;
    kept[size_t(c)] = keep(centre) ? w[size_t(c)] : 0.0;
    sum_kept += kept[size_t(c)];
  }
  const std::array<double, 8>& weights = sum_kept > 0.0 ? kept : w;
  const double norm = sum_kept > 0.0 ? 1.0 / sum_kept : 1.0;
  std::array<glm::vec4, 3> fetched{};
  for (int ch = 0; ch < 3; ++ch) {
    for (int c = 0; c < 8; ++c) {
      if (weights[size_t(c)] == 0.0) continue;
      const uint32_t q = volume.worldTexel(ch, g[size_t(c)]);
      const glm::vec4 x(float(q & 0xff), float(q >> 8 & 0xff), float(q >> 16 & 0xff), float(q >> 24));
      fetched[size_t(ch)] += float(weights[size_t(c)] * norm) * (x * (1.f / 255.f));
    }
    fetched[size_t(ch)] = decodeFetched(volume, fetched[size_t(ch)]);
  }
  return shadeFetched(volume, fetched, normal);
}

// Whether `probe` is covered; an invalid one (no resident probe: the sky fallback) is open.
bool covered(const ProbeCache& cache, ProbeRef probe) { return probe.valid() && (cache.flags(probe) & kProbeCovered); }
}  // namespace

glm::vec3 sampleVolumeFacing(const Volume& volume, const glm::dvec3& position, const glm::vec3& normal, float normal_offset_m) {
  return sampleKept(volume, position, normal, normal_offset_m,
                    [&](const glm::dvec3& centre) { return glm::dot(glm::dvec3(normal), centre - position) > 0.0; });
}

glm::vec3 sampleVolumeSided(const Volume& volume, const ProbeCache& cache, const glm::dvec3& position, const glm::vec3& normal,
                            float normal_offset_m) {
  // The point's side: that of the probe the index grid names at its offset sample. (The side of
  // the texel the sample falls in, one flag per texel as a texture would hold it, read worse: zdm2
  // 16.0 -> 16.9 %, the Cornell world 17.0 -> 17.5 %, 2026-12-07.) A texel's: that of the probe
  // its nearest fill took (ProbeCache::filledAt), which in a found room's cells is one outside.
  const bool side = covered(cache, cache.probeAt(position + glm::dvec3(normal) * double(normal_offset_m)));
  return sampleKept(volume, position, normal, normal_offset_m, [&](const glm::dvec3& centre) {
    return glm::dot(glm::dvec3(normal), centre - position) > 0.0 || covered(cache, cache.filledAt(centre)) == side;
  });
}

BasisColours fetchVolume(const Volume& volume, const glm::dvec3& position) {
  const VolumeShaderConstants k = volume.shaderConstants();
  const std::array<glm::vec4, 3> f = fetchAt(volume, k, glm::vec3(position - k.snapped_camera));
  BasisColours out;
  for (int b = 0; b < 4; ++b) out[b] = {f[0][b], f[1][b], f[2][b]};
  return out;
}

}  // namespace drtv::runtime
