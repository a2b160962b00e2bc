// The sweep (sweep.h), laid out for the loops that read it:
//  - the light flowing from one level to the next is a padded plane of (nx + 2 kPad) x
//    (ny + 2 kPad) floats per direction and channel (the pad ring holds the edges' light), so that
//    a row's gather is a contiguous loop per tap;
//  - a row's gathered light is structure-of-arrays (direction, channel, x): empty cells pass it on
//    with row copies, packing and averaging are loops over x, and only the cells with material
//    take the per-cell reflection;
//  - a path's transmittance through the cells it crosses, the product of their (1 - d)^len, comes
//    from factor planes made once per level, one per distinct crossed length (exp only in cells of
//    fractional density), and is skipped where the rows crossed hold no material. The first
//    version took exp of the summed optical depth per path, cell and channel: the same quantity up
//    to float rounding (tests/sweep/sweep_reference_test.cpp compares the two);
//  - the cell's own pass-through, (1 - d)^l, by its 5 distinct path lengths, not per direction.
// Here the sweeper, level by level and row by row; its gather paths (paths.h), the edges' light
// (edges.h) and its row kernels (row_kernels.h) are files of their own.
#include "drtv/sweep/sweep.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "drtv/formats/error.h"
#include "edges.h"
#include "paths.h"
#include "row_kernels.h"
#include "small_float.h"

namespace drtv::sweep {
namespace {

using namespace detail;

// One stream of light through the grid: a set of directions, its ping-pong level buffers. While a
// row is being swept, dst's row holds the light gathered into it, then what its cells store; the
// light the cells with material send on replaces theirs once the row is stored.
struct Pass {
  std::vector<int> bins;
  std::vector<BinPath> paths;
  bool direct = false;
  // A level's bins.size() * 3 planes (plane 3 b + c: bin b's channel c) of padded rows of w floats,
  // interleaved by row: padded row r of every plane, then row r + 1 of every plane. A row's gather
  // reads 11 source rows of every plane at once (the near-horizontal taps reach 5 rows away);
  // interleaved, those are 11 contiguous runs that the prefetcher follows, not 11 x 51 separate
  // streams (plane by plane, the gathers waited on memory: 44 % of their time on one tap's load).
  // Not initialised: the edges' fill writes all of src above the top level and dst's ring, and
  // the gather every interior row of dst before a level reads it.
  struct Buffer {
    std::unique_ptr<float[]> memory;
    // Padded row 0 of plane 0: its first cell (column kPad) on a 64-byte boundary, and with w a
    // multiple of kLanes every row's is: a row's gather stores, and the taps straight above its
    // cells load, whole cache lines (unaligned, each 16-lane access touched two).
    float* base = nullptr;
    // `floats` and kRowFloats more past them (storeCells reads rows in whole groups of 16).
    void allocate(size_t floats) {
      memory.reset(new float[floats + 2 * kRowFloats]);
      constexpr uintptr_t kMask = kRowFloats * sizeof(float) - 1;
      const uintptr_t first = reinterpret_cast<uintptr_t>(memory.get() + kPad);
      base = reinterpret_cast<float*>((first + kMask) & ~kMask) - kPad;
    }
  };
  Buffer src, dst;
  size_t w = 0;  // padded row length
  size_t planes() const { return bins.size() * 3; }
  size_t rowStride() const { return planes() * w; }
  float* srcRow(size_t plane, int r) const { return src.base + size_t(r) * rowStride() + plane * w; }
  float* dstRow(size_t plane, int r) const { return dst.base + size_t(r) * rowStride() + plane * w; }
};

class Sweeper {
 public:
  Sweeper(const MaterialGrid& m, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& o)
      : m_(m), g_(m.shape), o_(o), edges_(m.shape, sky, parent) {
    DRTV_CHECK(g_.size.x >= 1 && g_.size.y >= 1 && g_.size.z >= 1 && g_.cell_m > 0);
    DRTV_CHECK_EQ(m.density.size(), g_.cellCount());
    DRTV_CHECK_EQ(m.reflectance.size(), g_.cellCount());
    nx_ = g_.size.x;
    // Padded rows, rounded up so that every row of a level buffer starts its cells on a 64-byte
    // boundary (Pass::Buffer); the columns past nx + kPad are never filled nor used.
    w_ = (g_.size.x + 2 * kPad + kRowFloats - 1) / kRowFloats * kRowFloats;
    h_ = g_.size.y + 2 * kPad;
    plane_ = size_t(w_) * size_t(h_);
    // Optical depth per cell length, padded; outside the grid's sides: clear. Per level and padded
    // row, the span of cells with material (row_lo_ > row_hi_: none), and the cells of fractional
    // density (the only ones whose factors need exp).
    sigma_.assign(plane_ * size_t(g_.size.z), 0.f);
    level_has_material_.assign(size_t(g_.size.z), 0);
    row_lo_.assign(size_t(g_.size.z) * size_t(h_), w_);
    row_has_material_.assign(size_t(g_.size.z) * size_t(h_), 0);
    row_hi_.assign(size_t(g_.size.z) * size_t(h_), -1);
    fractional_.resize(size_t(g_.size.z));
    // Row by row: the clear and full cells in a vector loop (cell by cell, with a branch per
    // cell, this was 3 % of a re-sweep), log1p only in the cells of fractional density.
    const int nx = g_.size.x;
    for (int k = 0; k < g_.size.z; ++k)
      for (int j = 0; j < g_.size.y; ++j) {
        const float* d = m.density.data() + g_.index(0, j, k);
        const size_t row = size_t(k) * plane_ + size_t(j + kPad) * size_t(w_) + size_t(kPad);  // cell (0, j) in sigma_
        float* s = sigma_.data() + row;
        const DensityRow scan = opticalDepthRow(nx, d, s);
        if (scan.outside > 0)
          for (int i = 0; i < nx; ++i) DRTV_CHECK(d[i] >= 0.f && d[i] <= 1.f);
        if (scan.material == 0) continue;
        if (scan.fractional > 0)
          for (int i = 0; i < nx; ++i)
            if (d[i] > 0.f && d[i] < 1.f) s[i] = -std::log1p(-d[i]);
        int lo = 0, hi = nx - 1;
        while (lo < nx && !(s[lo] > 0)) ++lo;
        if (lo == nx) continue;  // log1p of a fractional density gave 0
        while (!(s[hi] > 0)) --hi;
        level_has_material_[size_t(k)] = 1;
        const size_t r = size_t(k) * size_t(h_) + size_t(j + kPad);
        row_has_material_[r] = 1;
        row_lo_[r] = lo + kPad;
        row_hi_[r] = hi + kPad;
        if (scan.fractional > 0)
          for (int i = lo; i <= hi; ++i)
            if (s[i] > 0 && s[i] < kInf) fractional_[size_t(k)].push_back(uint32_t(row - size_t(k) * plane_ + size_t(i)));
      }
    findSealed();
    for (int j = -kPad; j < g_.size.y + kPad; ++j)
      for (int i = -kPad; i < g_.size.x + kPad; ++i) {
        const Edges::Cell cell{i, j, size_t(j + kPad), size_t(i + kPad)};
        all_cells_.push_back(cell);
        if (i < 0 || j < 0 || i >= g_.size.x || j >= g_.size.y) ring_cells_.push_back(cell);
      }
    const auto& dirs = directions();
    for (int b = 0; b < kDirections; ++b) {
      float a = 0;
      for (int o = 0; o < kDirections; ++o)
        a += dirs[size_t(o)].solid_angle_sr * glm::dot(dirs[size_t(o)].travel, dirs[size_t(b)].travel);
      cos_sum_[size_t(b)] = a;
      travel_[size_t(b)] = dirs[size_t(b)].travel;
      omega_[size_t(b)] = dirs[size_t(b)].solid_angle_sr;
      unit_from_[size_t(b)] = glm::normalize(dirs[size_t(b)].mean_from);
    }
    full_.direct = false;
    for (int b = 0; b < kSwept; ++b) full_.bins.push_back(b);
    direct_.direct = true;
    direct_of_bin_.fill(-1);
    if (!o_.direct_sun || o_.keep_direct)
      for (int b = 0; b < kSwept; ++b)
        if (sky.sun[size_t(b)] != glm::vec3(0.f)) {
          direct_of_bin_[size_t(b)] = int(direct_.bins.size());
          direct_.bins.push_back(b);
        }
    for (Pass* p : {&full_, &direct_}) setUp(*p);
    up_.direct = false;
    for (int b = kSwept; b < kDirections; ++b) up_.bins.push_back(b);
    if (o_.bottom_up) setUp(up_);
    // The rows of a level without factors: never read (their bits in gather's mask are 0).
    no_factors_.assign(crossed_len_.size() * size_t(h_), sigma_.data());
    stride_ = (size_t(nx_) + kLanes - 1) / kLanes * kLanes;
    codes_.assign(size_t(kDirections) * stride_, 0u);
    // Rows of w_ floats like the level buffers', so that every row storeCells reads has its
    // channels w_ apart.
    // kLanes more: storeCells reads the last row past nx rounded up to kLanes, which can pass w_.
    up_half_.assign(size_t(3 * kUp) * size_t(w_) + kLanes, 0.f);
    store_rows_.stride = size_t(w_);
    average_.assign(stride_, 0u);
    dominant_.assign(stride_, 0u);
    for (int o = 0; o < kUp; ++o) {
      store_rows_.light[size_t(kSwept + o)] = up_half_.data() + size_t(3 * o) * size_t(w_);
    }
    for (int b = 0; b < kDirections; ++b) {
      store_rows_.from_x[size_t(b)] = unit_from_[size_t(b)].x;
      store_rows_.from_y[size_t(b)] = unit_from_[size_t(b)].y;
      store_rows_.from_z[size_t(b)] = unit_from_[size_t(b)].z;
    }
    batch_.assign(size_t(kBatchRows) * size_t(nx_), 0.f);
    leave_.assign(size_t(3 * kSwept) * size_t(nx_), 0.f);
    direct_leave_.assign(direct_.bins.size() * 3 * size_t(nx_), 0.f);
  }

  // sealed_: the full cells, eroded by one cell along x, then y, then z (above the grid's top is
  // open; past its sides and below its bottom, what the grid holds there is taken as full).
  void findSealed() {
    const int nx = g_.size.x, ny = g_.size.y, nz = g_.size.z;
    const size_t n = g_.cellCount();
    std::vector<uint8_t> a(n), b(n);
    for (size_t c = 0; c < n; ++c) a[c] = m_.density[c] >= 1.f;
    for (size_t row = 0; row < n / size_t(nx); ++row) {  // x
      const uint8_t* f = a.data() + row * size_t(nx);
      uint8_t* e = b.data() + row * size_t(nx);
      for (int i = 1; i < nx - 1; ++i) e[i] = f[i - 1] & f[i] & f[i + 1];
      e[0] = f[0] & f[std::min(1, nx - 1)];
      e[nx - 1] = f[std::max(nx - 2, 0)] & f[nx - 1];
    }
    for (int k = 0; k < nz; ++k)  // y
      for (int j = 0; j < ny; ++j) {
        uint8_t* e = a.data() + g_.index(0, j, k);
        const uint8_t *lo = b.data() + g_.index(0, std::max(j - 1, 0), k), *mid = b.data() + g_.index(0, j, k),
                      *hi = b.data() + g_.index(0, std::min(j + 1, ny - 1), k);
        for (int i = 0; i < nx; ++i) e[i] = lo[i] & mid[i] & hi[i];
      }
    sealed_.runs.clear();
    sealed_.first.assign(size_t(ny) * size_t(nz) + 1, 0);
    const size_t plane = size_t(nx) * size_t(ny);
    for (int k = 0; k < nz; ++k)  // z, and the runs
      for (int j = 0; j < ny; ++j) {
        sealed_.first[size_t(k) * size_t(ny) + size_t(j)] = sealed_.runs.size();
        if (k == nz - 1) continue;
        const uint8_t* mid = a.data() + g_.index(0, j, k);
        const uint8_t* hi = mid + plane;
        const uint8_t* lo = k > 0 ? mid - plane : mid;
        uint8_t* e = b.data() + g_.index(0, j, k);
        uint8_t any = 0;
        for (int i = 0; i < nx; ++i) any |= e[i] = lo[i] & mid[i] & hi[i];
        if (!any) continue;
        for (int i = 0; i < nx;) {
          if (!e[i]) {
            ++i;
            continue;
          }
          const int x0 = i;
          while (i < nx && e[i]) ++i;
          sealed_.runs.push_back({x0, i - x0});
        }
      }
    sealed_.first.back() = sealed_.runs.size();
  }

  // Sweeps into `out` (sweepInto). The light grid's words are all written below (each row's 26
  // words per cell, every cell's average and dominant direction), so its buffers are only sized,
  // never zeroed (Words: a fresh grid's 13.6 MB memset was 10 % of a 1 m sector's sweep); the
  // direct grid's words outside the sun's bins stay 0, so it is zeroed.
  void run(const SkyInput& sky, SweptGrid& out) {
    out.sky = sky;
    out.light_has_direct = o_.direct_sun;
    out.light.shape = g_;
    for (auto [v, n] : {std::pair{&out.light.light, g_.cellCount() * kDirections}, std::pair{&out.light.average, g_.cellCount()},
                        std::pair{&out.light.dominant, g_.cellCount()}})
      v->resize(n);
    if (o_.keep_unpacked)
      out.light.unpacked.resize(g_.cellCount() * kDirections);  // every value written (storeRow, bottomUp)
    else
      out.light.unpacked.clear();
    if (o_.keep_direct) {
      if (!out.direct) out.direct.emplace();
      out.direct->shape = g_;
      out.direct->light.assign(g_.cellCount() * kDirections, 0);
      out.direct->average.assign(g_.cellCount(), 0);
      out.direct->dominant.assign(g_.cellCount(), 0);
      if (o_.keep_unpacked)
        out.direct->unpacked.assign(g_.cellCount() * kDirections, glm::vec3(0.f));
      else
        out.direct->unpacked.clear();
    } else {
      out.direct.reset();
    }
    out.clear_z.clear();
    if (o_.bottom_up) {
      // The up-going pass adds to the cells' sums after the downward one: kept per row.
      down_sums_.resize(size_t(g_.size.y) * size_t(g_.size.z) * size_t(kSums) * stride_);
      emission_index_.assign(g_.cellCount(), -1);
      emission_.clear();
    }
    const int nz = g_.size.z;
    if (!m_.ground_z.empty()) {
      DRTV_CHECK_EQ(m_.ground_z.size(), size_t(g_.size.x) * size_t(g_.size.y));
      out.clear_z.resize(m_.ground_z.size());
      for (size_t c = 0; c < m_.ground_z.size(); ++c) {
        const int k = std::clamp(int(std::ceil((double(m_.ground_z[c]) - g_.origin.z) / g_.cell_m)), 0, nz - 1);
        out.clear_z[c] = float(g_.origin.z + (k + 0.5) * g_.cell_m);
      }
    }
    for (Pass* p : {&full_, &direct_})
      if (!p->bins.empty()) edges_.fill(nz, p->direct, p->bins, all_cells_, p->src.base, p->w, p->rowStride());
    for (int k = nz - 1; k >= 0; --k) {
      // The open sky's ring is the same at every level, and the levels never write it: both
      // buffers have it once the first level's is filled.
      if (k == nz - 1 || !edges_.sameAtEveryLevel())
        for (Pass* p : {&full_, &direct_})
          if (!p->bins.empty()) edges_.fill(k, p->direct, p->bins, ring_cells_, p->dst.base, p->w, p->rowStride());
      level(k, out);
      for (Pass* p : {&full_, &direct_}) std::swap(p->src, p->dst);
    }
    if (o_.bottom_up) bottomUp(out);
  }

 private:
  void setUp(Pass& p) {
    for (int b : p.bins) {
      BinPath path = pathGeometry(b);
      for (int t = 0; t < kTaps; ++t) path.taps[size_t(t)].w = t == 0 ? o_.smoothing : (1.f - o_.smoothing) / 4.f;  // as makePath
      for (Tap& t : path.taps) {
        DRTV_CHECK_LE(t.crossed.size(), size_t(kMaxCrossed));
        for (size_t i = 0; i < t.crossed.size(); ++i) {
          Crossed& c = t.crossed[i];
          c.len_id = lengthId(crossed_len_, c.len);
          DRTV_CHECK(c.dy >= -kPad && c.dy <= kPad);
          t.row[i] = c.len_id * h_ + kPad + c.dy;
          t.column[i] = kPad + c.dx;
          t.bit[i] = uint8_t((c.src_level ? kRowBits : 0) + c.dy + kPad);
          t.src_level[i] = c.src_level;
          t.mask |= 1u << t.bit[i];
        }
      }
      path.target_len_id = lengthId(target_len_, path.target_len);
      DRTV_CHECK_LE(target_len_.size(), kMaxTargetLengths);
      p.paths.push_back(std::move(path));
    }
    p.w = size_t(w_);
    p.src.allocate(p.bins.size() * 3 * plane_);
    p.dst.allocate(p.bins.size() * 3 * plane_);
  }

  static int lengthId(std::vector<float>& lengths, float len) {
    const auto it = std::find(lengths.begin(), lengths.end(), len);
    if (it != lengths.end()) return int(it - lengths.begin());
    lengths.push_back(len);
    return int(lengths.size()) - 1;
  }

  // Whether padded row r of level k holds material in padded columns [x0, x1].
  bool hasMaterial(int k, int r, int x0, int x1) const {
    const size_t i = size_t(k) * size_t(h_) + size_t(r);
    return row_lo_[i] <= x1 && row_hi_[i] >= x0;
  }

  // Level k's factor planes, (1 - d)^len = exp(-len sigma) per crossed length, valid in the rows
  // that hold material (the only ones read). Two levels are kept; the one holding `keep` stays.
  // As a table of rows (LevelFactors::rows): a row without cells of fractional density has the
  // same factors, 1 or 0, at every length, so its lengths share one row of a common plane; only the
  // rows with fractional cells have a row per length (filling every length's plane in full was
  // 1.8 % of a re-sweep).
  const float* const* factors(int k, int keep) {
    for (LevelFactors& f : factors_)
      if (f.level == k) return f.rows.data();
    LevelFactors& f = factors_[0].level == keep ? factors_[1] : factors_[0];
    f.level = k;
    const size_t lengths = crossed_len_.size(), w = size_t(w_);
    f.planes.resize((lengths + 1) * plane_ + kLanes);  // the lengths', then the common one; kLanes: gatherRow reads whole groups
    f.rows.resize(lengths * size_t(h_));
    const float* sig = sigma_.data() + size_t(k) * plane_;
    float* common = f.planes.data() + lengths * plane_;
    for (int r = 0; r < h_; ++r) {
      if (hasMaterial(k, r, 0, w_ - 1)) clearOrFull(w_, sig + size_t(r) * w, common + size_t(r) * w);
      for (size_t l = 0; l < lengths; ++l) f.rows[l * size_t(h_) + size_t(r)] = common + size_t(r) * w;
    }
    const std::vector<uint32_t>& fractional = fractional_[size_t(k)];  // in row order
    for (size_t a = 0; a < fractional.size();) {
      const size_t r = fractional[a] / w;
      size_t b = a;
      while (b < fractional.size() && fractional[b] / w == r) ++b;
      for (size_t l = 0; l < lengths; ++l) {
        float* out = f.planes.data() + l * plane_ + r * w;
        std::copy_n(common + r * w, w, out);
        const float len = crossed_len_[l];
        for (size_t i = a; i < b; ++i) out[fractional[i] - r * w] = std::exp(-(len * sig[fractional[i]]));
        f.rows[l * size_t(h_) + r] = out;
      }
      a = b;
    }
    return f.rows.data();
  }

  // Gathers row j of level k (source level k_src) into p.dst's row, and into q->dst's for the
  // bins q shares with p (the direct pass: a subset of the same bins, the same paths).
  void gather(Pass& p, Pass* q, int k, int k_src, int j, int x0, int n) {
    const bool src_in = k_src >= 0 && k_src < g_.size.z;
    const bool target_material = level_has_material_[size_t(k)] != 0;
    const bool src_material = src_in && level_has_material_[size_t(k_src)] != 0;
    // A crossed cell is taken if its row holds material at all: where it holds none within the
    // row's cells, its factors there are 1, and multiplying by 1 changes nothing.
    const float* const* rows_target = target_material ? factors(k, src_material ? k_src : k) + j : nullptr;
    const float* const* rows_src = src_material ? factors(k_src, k) + j : nullptr;
    // Bit kPad + dy (kRowBits + kPad + dy): row j + dy of the target's (source's) level holds
    // material and has factors.
    uint64_t lit = 0;
    for (int dy = -kPad; dy <= kPad; ++dy) {
      const size_t r = size_t(j + kPad + dy);
      if (rows_target && row_has_material_[size_t(k) * size_t(h_) + r]) lit |= uint64_t(1) << (kPad + dy);
      if (rows_src && row_has_material_[size_t(k_src) * size_t(h_) + r]) lit |= uint64_t(1) << (kRowBits + kPad + dy);
    }
    // A pointer that is never read where a level has no factors (its bits are 0).
    const float* const* rows[2] = {rows_target ? rows_target : no_factors_.data() + j, rows_src ? rows_src : no_factors_.data() + j};
    TapRows g;
    for (size_t b = 0; b < p.bins.size(); ++b) {
      const BinPath& path = p.paths[b];
      bool any = false;
      for (int t = 0; t < kTaps; ++t) {
        const Tap& tap = path.taps[size_t(t)];
        g.w[size_t(t)] = tap.w;
        int nf = 0;
        if (tap.mask & lit) {
          // Branch-free, in the crossed cells' order (the order the factors multiply in).
          for (size_t c = 0; c < tap.crossed.size(); ++c) {
            g.f[size_t(t)][size_t(nf)] = rows[tap.src_level[c]][tap.row[c]] + tap.column[c] + x0;
            nf += int((lit >> tap.bit[c]) & 1u);
          }
        }
        g.nf[size_t(t)] = nf;
        any = any || nf > 0;
      }
      if (prefetch_) {
        // The row's grid words, written by storeRow after the gathers: their cache lines fetched
        // a few at a time during the gathers. Fetched all at once, the prefetches stalled on the
        // line fill buffers; not at all, the transposition's stores waited on them (18 % of a
        // re-sweep's samples).
        const size_t bytes = size_t(n) * kDirections * sizeof(uint32_t), lines = (bytes + 63) / 64;
        const size_t per_bin = (lines + p.bins.size() - 1) / p.bins.size();
        for (size_t l = b * per_bin; l < std::min(lines, (b + 1) * per_bin); ++l) __builtin_prefetch(prefetch_ + 64 * l, 1, 3);
      }
      gatherDirection(p, b, path, any, j, x0, n, g);
      if (q && direct_of_bin_[size_t(path.bin)] >= 0) gatherDirection(*q, size_t(direct_of_bin_[size_t(path.bin)]), path, any, j, x0, n, g);
    }
  }

  // Direction b of pass p along row j, with the taps' weights in g.
  void gatherDirection(Pass& p, size_t b, const BinPath& path, bool varying, int j, int x0, int n, TapRows& g) {
    for (int t = 0; t < kTaps; ++t) {
      const Tap& tap = path.taps[size_t(t)];
      g.s[size_t(t)] = p.srcRow(b * 3, j + kPad + tap.oy) + kPad + tap.ox + x0;
    }
    g.a = p.dstRow(b * 3, j + kPad) + kPad + x0;
    g.stride = p.w;  // a row's planes follow each other (Pass)
    if (varying)
      gatherRow<true>(n, g);
    else
      gatherRow<false>(n, g);
  }

  // Sets the light of pass p in cells [x0, x0 + n) of row j to 0 (every bin and channel).
  void zeroCells(Pass& p, int j, int x0, int n) {
    for (size_t plane = 0; plane < p.planes(); ++plane) std::fill_n(p.dstRow(plane, j + kPad) + kPad + x0, n, 0.f);
  }

  // Row j of level k, window by window: the row's cells less its long runs of sealed cells
  // (Sealed), which gather nothing, so store and send on 0 without being swept.
  void level(int k, SweptGrid& out) {
    Pass* q = direct_.bins.empty() ? nullptr : &direct_;
    for (int j = 0; j < g_.size.y; ++j) {
      const size_t r = size_t(k) * size_t(g_.size.y) + size_t(j);
      const Run* runs = sealed_.runs.data() + sealed_.first[r];
      const size_t nruns = sealed_.first[r + 1] - sealed_.first[r];
      int x0 = 0;
      size_t window_first_run = 0;  // the runs since the last skipped one: the window's short runs
      for (size_t i = 0; i <= nruns; ++i) {
        const bool last = i == nruns;
        if (!last && runs[i].n < kSkippedRun) continue;
        const int x1 = last ? nx_ : runs[i].x0;
        if (x1 > x0) {
          prefetch_ = reinterpret_cast<const char*>(out.light.light.data() + (g_.index(0, j, k) + size_t(x0)) * kDirections);
          gather(full_, q, k, k + 1, j, x0, x1 - x0);
          prefetch_ = nullptr;
          for (size_t s = window_first_run; s < i; ++s)  // gathered, then 0
            for (Pass* p : {&full_, &direct_}) zeroCells(*p, j, runs[s].x0, runs[s].n);
          interactRow(k, j, x0, x1);
          storeRow(k, j, x0, x1 - x0, out);
          // What the cells with material send on replaces what they stored.
          for (const auto& [p, leave] : {std::pair{&full_, &leave_}, std::pair{&direct_, &direct_leave_}})
            if (span_n_ > 0 && p->planes() > 0)
              copyRows(int(p->planes()), span_n_, leave->data(), size_t(nx_), p->dstRow(0, j + kPad) + kPad + span_lo_, p->w);
        }
        if (last) break;
        for (Pass* p : {&full_, &direct_}) zeroCells(*p, j, runs[i].x0, runs[i].n);
        storeSealed(k, j, runs[i].x0, runs[i].n, out);
        x0 = runs[i].x0 + runs[i].n;
        window_first_run = i + 1;
      }
    }
  }

  // The words of sealed cells [x0, x0 + n) of row j, level k: 0, as the sweep would store them
  // with no light (the direct grid's words are 0 already).
  void storeSealed(int k, int j, int x0, int n, SweptGrid& out) {
    const size_t cell0 = g_.index(x0, j, k);
    std::fill_n(out.light.light.data() + cell0 * kDirections, size_t(n) * kDirections, 0u);
    std::fill_n(out.light.average.data() + cell0, n, 0u);
    std::fill_n(out.light.dominant.data() + cell0, n, 0u);
    if (o_.keep_unpacked) std::fill_n(out.light.unpacked.data() + cell0 * kDirections, size_t(n) * kDirections, glm::vec3(0.f));
    if (o_.bottom_up) {
      float* sums = down_sums_.data() + (size_t(k) * size_t(g_.size.y) + size_t(j)) * size_t(kSums) * stride_ + size_t(x0);
      for (int row = 0; row < kSums; ++row) std::fill_n(sums + size_t(row) * stride_, n, 0.f);
    }
  }

  // Batch row `r` (of nx floats).
  float* batch(int r) { return batch_.data() + size_t(r) * size_t(nx_); }

  // The span of row j, level k, from its first to its last cell with material, as one batch: what
  // passes and what is reflected (sweep.h), per cell in the reference's order of operations, as
  // loops over the span. Its empty cells come out as they went in (T = 1 stops nothing, so nothing
  // is reflected: exactly, in floats too). The stored light goes into dst's row in place (both
  // passes), the light sent on into leave_ / direct_leave_, the up-going reflected light into the
  // batch's emission rows.
  void interactRow(int k, int j, int x0, int x1) {
    const int nx = nx_;
    const size_t r = size_t(k) * size_t(h_) + size_t(j + kPad);
    span_lo_ = 0;
    span_n_ = 0;
    const int lo = std::max(row_lo_[r] - kPad, x0), hi = std::min(row_hi_[r] - kPad, x1 - 1);
    if (lo > hi) return;
    const int n = hi - lo + 1;
    span_lo_ = lo;
    span_n_ = n;
    const size_t row = size_t(j + kPad) * size_t(w_) + size_t(kPad + lo);  // the span's first cell
    const float* sig = sigma_.data() + size_t(k) * plane_ + row;
    float* tau = batch(kTau);
    float* fa = batch(kFa);
    float* fb = batch(kFb);
    const size_t lengths = target_len_.size();
    // The cells' own pass-through per distinct path length: 1 in an empty cell, 0 in a full one
    // (row loops), exp in the cells of fractional density (patched in after).
    clearOrFull(n, sig, tau);
    copyRows(int(lengths), n, tau, 0, batch(kT), size_t(nx));
    copyRows(int(lengths), n, tau, 0, batch(kSqrtT), size_t(nx));
    for (int m = 0; m < n; ++m) {
      const float s = sig[m];
      if (s == 0.f || s == kInf) continue;
      tau[m] = std::exp(-s);
      for (size_t l = 0; l < lengths; ++l) {
        const float t = std::exp(-s * target_len_[l]);
        batch(kT + int(l))[m] = t;
        batch(kSqrtT + int(l))[m] = std::sqrt(t);
      }
    }
    halfSums(n, tau, fa, fb);
    static_assert(sizeof(glm::vec3) == 3 * sizeof(float));
    splitRgb(n, &m_.reflectance[g_.index(lo, j, k)].x, batch(kRho), batch(kRho + 1), batch(kRho + 2));
    auto in = [&](int b, int c) { return full_.dstRow(size_t(3 * b + c), j + kPad) + kPad + lo; };
    // What each direction loses in the cell, I (1 - T), normalised, summed as sum and q (columns
    // x, y, z of sum_i q_i travel_i, per channel); then the reflected light per outgoing direction.
    ReflectionRows rows{tau, fa, fb, {batch(kRho), batch(kRho + 1), batch(kRho + 2)}, {}, {}};
    for (int c = 0; c < 3; ++c) rows.sum[c] = batch(kSum + c);
    for (int p = 0; p < 9; ++p) rows.q[p] = batch(kQ + p);
    for (int p = 0; p < 12; ++p) std::fill_n(batch(kSum + p), n, 0.f);
    for (int b = 0; b < kSwept; ++b) {
      const glm::vec3 u = travel_[size_t(b)];
      addStopped(n, rows, in(b, 0), in(b, 1), in(b, 2), batch(kT + full_.paths[size_t(b)].target_len_id), cos_sum_[size_t(b)], u.x, u.y, u.z);
    }
    for (int o = 0; o < kDirections; ++o) {
      const glm::vec3 u = travel_[size_t(o)];
      if (o < kSwept) {
        const int l = full_.paths[size_t(o)].target_len_id;
        float* leave = leave_.data() + size_t(3 * o) * size_t(nx);
        reflectDown(n, rows, u.x, u.y, u.z, omega_[size_t(o)], batch(kT + l), batch(kSqrtT + l), in(o, 0), in(o, 1), in(o, 2), leave,
                    leave + nx, leave + 2 * nx);
      } else {
        const int e = kEmission + 3 * (o - kSwept);
        reflectUp(n, rows, u.x, u.y, u.z, omega_[size_t(o)], batch(e), batch(e + 1), batch(e + 2));
      }
    }
    // The sun's unscattered light: the same attenuation, no reflection.
    for (size_t d = 0; d < direct_.bins.size(); ++d) {
      const int l = direct_.paths[d].target_len_id;
      const float *t = batch(kT + l), *st = batch(kSqrtT + l);
      for (int c = 0; c < 3; ++c) {
        float* dst = direct_.dstRow(d * 3 + size_t(c), j + kPad) + kPad + lo;
        float* leave = direct_leave_.data() + (d * 3 + size_t(c)) * size_t(nx);
        for (int m = 0; m < n; ++m) {
          const float v = dst[m];
          leave[m] = v * t[m];
          dst[m] = v * st[m];
        }
      }
    }
    if (o_.bottom_up)  // the up-going pass adds the cells' reflection to the light it carries
      for (int m = 0; m < n; ++m) {
        const size_t cell = g_.index(lo + m, j, k);
        if (sig[m] == 0.f || m_.reflectance[cell] == glm::vec3(0.f)) continue;
        emission_index_[cell] = int(emission_.size());
        std::array<glm::vec3, kUp>& e = emission_.emplace_back();
        for (int o = 0; o < kUp; ++o)
          for (int c = 0; c < 3; ++c) e[size_t(o)][c] = batch(kEmission + 3 * o + c)[m];
      }
  }

  // Packs row j of level k's stored light (dst's rows) into the grids, with the cells' average and
  // dominant direction.
  void storeRow(int k, int j, int x0, int nx, SweptGrid& out) {
    const size_t cell0 = g_.index(x0, j, k);
    StoreRows rows = store_rows_;
    for (int b = 0; b < kSwept; ++b) {
      const float* r = full_.dstRow(size_t(3 * b), j + kPad) + kPad + x0;
      rows.light[size_t(b)] = r;
      const int d = direct_of_bin_[size_t(b)];
      rows.direct[size_t(b)] = d >= 0 ? direct_.dstRow(size_t(3 * d), j + kPad) + kPad + x0 : nullptr;
    }
    for (int o = kSwept; o < kDirections; ++o) rows.light[size_t(o)] += x0;
    if (out.direct)
      for (size_t d = 0; d < direct_.bins.size(); ++d) {
        const float* r = direct_.dstRow(d * 3, j + kPad) + kPad + x0;
        uint32_t* dst = out.direct->light.data() + cell0 * kDirections + size_t(direct_.bins[d]);
        for (int x = 0; x < nx; ++x) dst[size_t(x) * kDirections] = detail::packR11G11B10(r[x], r[w_ + x], r[2 * w_ + x]);
        if (o_.keep_unpacked) {
          glm::vec3* u = out.direct->unpacked.data() + cell0 * kDirections + size_t(direct_.bins[d]);
          for (int x = 0; x < nx; ++x) u[size_t(x) * kDirections] = {r[x], r[w_ + x], r[2 * w_ + x]};
        }
      }
    uint32_t* grid = out.light.light.data() + cell0 * kDirections;
    rows.first = 0;
    if (o_.bottom_up) {  // the up-going light comes later (bottomUp); its words are 0 in codes_
      rows.end = kSwept;
      // storeCells writes whole groups of kLanes: into a row of its own, then the window's cells.
      float* sums = down_sums_.data() + (size_t(k) * size_t(g_.size.y) + size_t(j)) * size_t(kSums) * stride_ + size_t(x0);
      sums_row_.resize(size_t(kSums) * stride_);
      if (o_.direct_sun)
        storeCells<false, false>(nx, rows, codes_.data(), stride_, sums_row_.data(), stride_, nullptr, nullptr);
      else
        storeCells<true, false>(nx, rows, codes_.data(), stride_, sums_row_.data(), stride_, nullptr, nullptr);
      for (int row = 0; row < kSums; ++row) std::copy_n(sums_row_.data() + size_t(row) * stride_, nx, sums + size_t(row) * stride_);
      transposeCodes(codes_.data(), stride_, nx, grid);
      if (o_.keep_unpacked) keepUnpacked(rows, nx, cell0, out);
      return;
    }
    // The up-going directions without the bottom-up pass: the cells' own reflected light, halved;
    // 0 outside the span (the rows' previous span is cleared), which adds nothing to the sums.
    const int n = span_n_, lo = span_lo_;
    for (int row = 0; row < 3 * kUp; ++row) {
      float* half = up_half_.data() + size_t(row) * size_t(w_);
      std::fill_n(half + half_lo_, half_n_, 0.f);
      const float* e = batch(kEmission + row);
      for (int m = 0; m < n; ++m) half[lo + m] = 0.5f * e[m];
    }
    half_lo_ = lo;
    half_n_ = n;
    rows.end = kDirections;
    if (o_.direct_sun)
      storeCells<false, true>(nx, rows, codes_.data(), stride_, nullptr, 0, average_.data(), dominant_.data());
    else
      storeCells<true, true>(nx, rows, codes_.data(), stride_, nullptr, 0, average_.data(), dominant_.data());
    transposeCodes(codes_.data(), stride_, nx, grid);
    std::memcpy(out.light.average.data() + cell0, average_.data(), size_t(nx) * sizeof(uint32_t));
    std::memcpy(out.light.dominant.data() + cell0, dominant_.data(), size_t(nx) * sizeof(uint32_t));
    if (o_.keep_unpacked) keepUnpacked(rows, nx, cell0, out);
  }

  // keep_unpacked: the values storeCells packed for directions [rows.first, rows.end) of the row
  // whose first cell is cell0, as it had them (the sun's unscattered part taken off and clamped
  // at 0 in the down-going directions, unless direct_sun), into out.light.unpacked.
  void keepUnpacked(const StoreRows& rows, int nx, size_t cell0, SweptGrid& out) const {
    glm::vec3* u = out.light.unpacked.data() + cell0 * kDirections;
    const size_t s = rows.stride;
    for (int d = rows.first; d < rows.end; ++d) {
      const float* l = rows.light[size_t(d)];
      const float* direct = d < kSwept && !o_.direct_sun ? rows.direct[size_t(d)] : nullptr;
      for (int x = 0; x < nx; ++x) {
        glm::vec3 v(l[x], l[s + x], l[2 * s + x]);
        if (d < kSwept && !o_.direct_sun) {
          if (direct) v -= glm::vec3(direct[x], direct[s + x], direct[2 * s + x]);
          v = glm::max(v, glm::vec3(0.f));
        }
        u[size_t(x) * kDirections + size_t(d)] = v;
      }
    }
  }

  // The up-going directions carried up from the bottom level (bottom_up), then the cells'
  // average and dominant direction.
  void bottomUp(SweptGrid& out) {
    const int nx = nx_, ny = g_.size.y, nz = g_.size.z;
    // Per row: the up-going paths' pass-through T and sqrt T per distinct path length, and what
    // the cells reflect up (0 where they reflect nothing), 3 rows per direction.
    std::vector<float> lengths;
    std::array<int, kUp> length_of{};
    for (int o = 0; o < kUp; ++o) length_of[size_t(o)] = lengthId(lengths, up_.paths[size_t(o)].target_len);
    std::vector<float> t(2 * lengths.size() * stride_), e(size_t(3 * kUp) * stride_, 0.f);
    std::fill_n(up_.src.base, up_.bins.size() * 3 * plane_, 0.f);  // below the grid: nothing comes up
    StoreRows& rows = store_rows_;  // light[kSwept + o]: up_half_'s rows, the stored light
    rows.first = kSwept;
    rows.end = kDirections;
    for (int k = 0; k < nz; ++k) {
      edges_.fill(k, false, up_.bins, ring_cells_, up_.dst.base, up_.w, up_.rowStride());
      for (int j = 0; j < ny; ++j) {
        gather(up_, nullptr, k, k - 1, j, 0, nx);
        {
          const size_t r = size_t(k) * size_t(ny) + size_t(j);
          for (size_t s = sealed_.first[r]; s < sealed_.first[r + 1]; ++s) zeroCells(up_, j, sealed_.runs[s].x0, sealed_.runs[s].n);
        }
        const float* sig = sigma_.data() + size_t(k) * plane_ + size_t(j + kPad) * size_t(w_) + size_t(kPad);
        for (size_t l = 0; l < lengths.size(); ++l) {
          float* tl = t.data() + 2 * l * stride_;
          float* stl = tl + stride_;
          for (int x = 0; x < nx; ++x) {
            const float s = sig[x];
            tl[x] = s == 0.f ? 1.f : std::exp(-s * lengths[l]);
            stl[x] = std::sqrt(tl[x]);
          }
        }
        const size_t cell0 = g_.index(0, j, k);
        for (int x = 0; x < nx; ++x) {
          const int at = emission_index_[cell0 + size_t(x)];
          for (int o = 0; o < kUp; ++o)
            for (int c = 0; c < 3; ++c)
              e[size_t(3 * o + c) * stride_ + size_t(x)] = at < 0 ? 0.f : emission_[size_t(at)][size_t(o)][c];
        }
        for (int o = 0; o < kUp; ++o) {
          const float* tl = t.data() + 2 * size_t(length_of[size_t(o)]) * stride_;
          upCells(nx, up_.dstRow(size_t(3 * o), j + kPad) + kPad, size_t(w_), tl, tl + stride_, e.data() + size_t(3 * o) * stride_, stride_,
                  up_half_.data() + size_t(3 * o) * size_t(w_));
        }
        float* sums = down_sums_.data() + (size_t(k) * size_t(ny) + size_t(j)) * size_t(kSums) * stride_;
        storeCells<false, true, true>(nx, rows, codes_.data(), stride_, sums, stride_, average_.data(), dominant_.data());
        uint32_t* grid = out.light.light.data() + cell0 * kDirections;
        for (int x = 0; x < nx; ++x)
          for (int o = kSwept; o < kDirections; ++o) grid[size_t(x) * kDirections + size_t(o)] = codes_[size_t(o) * stride_ + size_t(x)];
        if (o_.keep_unpacked) keepUnpacked(rows, nx, cell0, out);
        std::memcpy(out.light.average.data() + cell0, average_.data(), size_t(nx) * sizeof(uint32_t));
        std::memcpy(out.light.dominant.data() + cell0, dominant_.data(), size_t(nx) * sizeof(uint32_t));
      }
      std::swap(up_.src, up_.dst);
    }
  }

  // Distinct path lengths a cell attenuates itself: straight, the 4 side diagonals, the 4 corner
  // diagonals, and the two kinds of near-horizontal path (directions.h), one way or the other.
  static constexpr size_t kMaxTargetLengths = 8;
  // Row sums of a cell's stored light: rgb, luminance, luminance-weighted unit source direction.
  static constexpr int kSums = 7;
  // The batch's rows (of nx floats), per cell of the span: pass-through, reflectance, the sums of
  // what is stopped, the up-going reflected light, and one direction's halved emission.
  static constexpr int kTau = 0;
  static constexpr int kFa = kTau + 1;
  static constexpr int kFb = kFa + 1;
  static constexpr int kT = kFb + 1;
  static constexpr int kSqrtT = kT + int(kMaxTargetLengths);
  static constexpr int kRho = kSqrtT + int(kMaxTargetLengths);
  static constexpr int kSum = kRho + 3;
  static constexpr int kQ = kSum + 3;
  static constexpr int kEmission = kQ + 9;
  static constexpr int kBatchRows = kEmission + 3 * kUp;

  struct LevelFactors {
    int level = std::numeric_limits<int>::min();
    std::vector<float> planes;  // crossed_len_.size() planes, then the common one (factors)
    std::vector<const float*> rows;  // per length l and padded row r, [l h_ + r]: its factors' row
  };

  // Runs of sealed cells, a full cell whose neighbours in the grid are full too (within a hill):
  // no light reaches it through them, so it gathers none (sweep.h). Per row r = k ny + j, runs
  // [first[r], first[r + 1]) in x order.
  struct Run {
    int x0, n;
  };
  struct Sealed {
    std::vector<Run> runs;
    std::vector<size_t> first;
  };
  // Runs at least this long are not swept (Sweeper::level); shorter ones are swept and zeroed.
  static constexpr int kSkippedRun = 16;

  const MaterialGrid& m_;
  GridShape g_;
  SweepOptions o_;
  Edges edges_;
  Sealed sealed_;
  int nx_ = 0, w_ = 0, h_ = 0;
  size_t plane_ = 0;
  std::vector<float> sigma_;
  std::vector<uint8_t> level_has_material_;
  std::vector<int> row_lo_, row_hi_;
  std::vector<uint8_t> row_has_material_;  // per level and padded row: row_lo_ <= row_hi_
  std::vector<std::vector<uint32_t>> fractional_;
  std::vector<float> crossed_len_, target_len_;
  std::array<LevelFactors, 2> factors_;
  std::vector<const float*> no_factors_;  // as LevelFactors::rows, for a level without material
  std::vector<Edges::Cell> all_cells_, ring_cells_;
  std::array<float, kDirections> cos_sum_{}, omega_{};
  std::array<glm::vec3, kDirections> travel_{}, unit_from_{};
  Pass full_, direct_, up_;
  std::array<int, kSwept> direct_of_bin_{};
  // The row's words, direction-major (kDirections rows of nx), transposed into the grid
  // (transposeCodes).
  std::vector<uint32_t> codes_;
  const char* prefetch_ = nullptr;  // the grid's words of the row being swept (level)
  size_t stride_ = 0;             // nx_ rounded up to kLanes: the rows of codes_, average_, down_sums_
  // 3 kUp rows of w_: the up-going light as stored (the cells' reflection halved, or with
  // bottom_up what bottomUp carried up), read by storeCells.
  std::vector<float> up_half_;
  int half_lo_ = 0, half_n_ = 0;  // the cells of up_half_ not 0: the last row's span
  std::vector<uint32_t> average_, dominant_;  // one row each: storeCells' words before the grid's
  StoreRows store_rows_;
  int span_lo_ = 0, span_n_ = 0;  // the row's span of cells with material (interactRow)
  std::vector<float> batch_;     // kBatchRows rows of nx
  std::vector<float> leave_, direct_leave_;  // per pass, bins * 3 rows of nx: what the batch sends on
  std::vector<float> down_sums_;  // bottom_up: per row of the grid, the kSums rows of its cells' sums
  std::vector<float> sums_row_;   // bottom_up: one window's sums (storeRow)
  std::vector<int> emission_index_;
  std::vector<std::array<glm::vec3, kUp>> emission_;
};

}  // namespace

void sweepInto(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options,
               SweptGrid& out) {
  DRTV_CHECK(options.smoothing >= 0.f && options.smoothing <= 1.f);
  DRTV_CHECK(parent != &out);
  Sweeper s(material, sky, parent, options);
  s.run(sky, out);
}

SweptGrid sweep(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options) {
  SweptGrid out;
  sweepInto(material, sky, parent, options, out);
  return out;
}

}  // namespace drtv::sweep
