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
#include "drtv/sweep/sweep.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <vector>

#include <glm/gtc/packing.hpp>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "drtv/formats/error.h"
#include "simd_clones.h"
#include "small_float.h"

// The 8-lane helpers below are inlined into the row loops (always_inline), so how a 32-byte vector
// is passed to a function without AVX, which GCC warns about here, never arises.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace drtv::sweep {
namespace {

// The row loops are compiled three times, for the baseline, AVX2 and x86-64-v4 (AVX-512), chosen
// at run time by what the CPU supports: the same IEEE operations in the same order, so the same results (no FMA: the
// v4 code could fuse a * b + c, which -ffp-contract=off for this file forbids, sweep/CMakeLists.txt).
// The scalar loops as DRTV_SIMD_CLONES (simd_clones.h); the vector ones (storeCells, gatherRow)
// as one body per lane count, 16 lanes for x86-64-v4 and 8 otherwise, chosen by isa(): the AVX2
// body's target is "avx2", the lanes it was tuned for. Where DRTV_SIMD_MULTIVERSION is 0 (the
// sanitizers, Clang), the baseline's 8 lanes only.
#if DRTV_SIMD_MULTIVERSION
enum class Isa { kBase, kAvx2, kV4 };
Isa isa() {
  static const Isa i = __builtin_cpu_supports("x86-64-v4") ? Isa::kV4 : __builtin_cpu_supports("avx2") ? Isa::kAvx2 : Isa::kBase;
  return i;
}
#endif

constexpr int kPad = kNearHorizontalStep + 1;  // the farthest source: 4 sideways + 1 smoothing tap
constexpr int kTaps = 5;
constexpr float kFourPi = 12.566370614359172f;
constexpr float kInf = std::numeric_limits<float>::infinity();

// A material cell a gathered path crosses between its source and its target: offset from the
// target, on the target's level (src_level false) or the source's, and the length in cell units.
struct Crossed {
  int dx, dy;
  bool src_level;
  float len;
  int len_id = -1;  // its length's factor plane (Sweeper::crossed_len_)
};
// The most material cells one tap's path crosses (makePath; checked in Sweeper::setUp).
constexpr int kMaxCrossed = 8;
// Bit of a crossed cell's factor row in a gathered row's mask of rows with material (Sweeper::
// gather): rows dy = -kPad..kPad of the target's level, then of the source's.
constexpr int kRowBits = 2 * kPad + 1;
struct Tap {
  int ox, oy;  // source offset from the target, cells
  float w;
  std::vector<Crossed> crossed;
  // The crossed cells flattened for the gather (Sweeper::setUp): their factor rows (the index in a
  // level's table of factor rows, LevelFactors::rows, less the target's row j) and columns (the
  // offset from the target's padded column), row bits, and the union of those bits.
  std::array<int, kMaxCrossed> row{};
  std::array<int, kMaxCrossed> column{};
  std::array<uint8_t, kMaxCrossed> bit{};
  std::array<uint8_t, kMaxCrossed> src_level{};
  uint32_t mask = 0;
};
struct BinPath {
  int bin;
  std::array<Tap, kTaps> taps;
  float target_len;      // the path length the target cell itself attenuates
  int target_len_id = -1;  // Sweeper::target_len_
};

BinPath makePath(int bin, float smoothing) {
  const glm::ivec3 st = directions()[size_t(bin)].sweep_step;
  static constexpr int kTx[kTaps] = {0, 1, -1, 0, 0}, kTy[kTaps] = {0, 0, 0, 1, -1};
  BinPath p;
  p.bin = bin;
  for (int j = 0; j < kTaps; ++j) {
    Tap& t = p.taps[size_t(j)];
    t.ox = -st.x + kTx[j];
    t.oy = -st.y + kTy[j];
    t.w = j == 0 ? smoothing : (1.f - smoothing) / 4.f;
    // The segment between the centres, sampled at 512 midpoints: a cell's length is its samples'.
    const glm::dvec3 a(t.ox, t.oy, -st.z);
    constexpr int kSamples = 512;
    const double step_len = glm::length(a) / kSamples;
    for (int m = 0; m < kSamples; ++m) {
      const glm::dvec3 q = a * (1.0 - (m + 0.5) / kSamples);
      const glm::ivec3 c(glm::floor(q + 0.5));
      if (c == glm::ivec3(a) || c == glm::ivec3(0)) continue;
      auto it = std::find_if(t.crossed.begin(), t.crossed.end(),
                             [&](const Crossed& x) { return x.dx == c.x && x.dy == c.y && x.src_level == (c.z != 0); });
      if (it == t.crossed.end()) t.crossed.push_back({c.x, c.y, c.z != 0, 0.f}), it = t.crossed.end() - 1;
      it->len += float(step_len);
    }
  }
  float crossed = 0;
  for (const Crossed& c : p.taps[0].crossed) crossed += c.len;
  p.target_len = float(glm::length(glm::dvec3(st))) - crossed;
  return p;
}

// The paths of direction `bin` without their weights (makePath's crossed cells and lengths, which
// do not depend on the smoothing), computed once. Thread-safe (a function-local static).
const BinPath& pathGeometry(int bin) {
  static const std::array<BinPath, kDirections> paths = [] {
    std::array<BinPath, kDirections> a;
    for (int b = 0; b < kDirections; ++b) a[size_t(b)] = makePath(b, 0.f);
    return a;
  }();
  return paths[size_t(bin)];
}


// The edges' light: the open sky, or a coarser grid decoded once around this one.
class Edges {
 public:
  Edges(const GridShape& g, const SkyInput& sky, const SweptGrid* parent) : g_(g), sky_(sky), parent_(parent) {
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

 private:
  GridShape g_;
  SkyInput sky_;
  const SweptGrid* parent_;
  int i0_ = 0, j0_ = 0, ni_ = 0, nj_ = 0;
  std::vector<LightVector> full_, direct_, slice_;
};

// The level buffers' rows are padded to a multiple of this many floats (64 bytes, 16 lanes).
constexpr int kRowFloats = 16;

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

// A row's words from direction-major (codes[d * stride + x]) to the light grid's cell-major layout
// (grid[x * kDirections + d]). Word by word, each store was a lane extracted from a vector: the
// packing's strided stores and the copy of the row into the grid took 15 % of the sweep. With
// AVX2, 8 x 8 blocks are transposed in registers and stored 8 words at a time. Data movement
// only: both versions write the same words.
void transposeCodesScalar(const uint32_t* codes, size_t stride, int n, uint32_t* grid, int x0) {
  for (int x = x0; x < n; ++x)
    for (int d = 0; d < kDirections; ++d) grid[size_t(x) * kDirections + size_t(d)] = codes[size_t(d) * stride + size_t(x)];
}
#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx2"))) void transposeCodesAvx2(const uint32_t* codes, size_t stride, int n, uint32_t* grid) {
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    for (int d0 = 0; d0 + 8 <= kDirections; d0 += 8) {
      __m256 r[8];  // directions d0..d0 + 7 of cells x..x + 7
      for (int i = 0; i < 8; ++i) r[i] = _mm256_loadu_ps(reinterpret_cast<const float*>(codes + size_t(d0 + i) * stride + size_t(x)));
      const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
      const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
      const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
      const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
      const __m256 u0 = _mm256_shuffle_ps(t0, t2, 0x44), u1 = _mm256_shuffle_ps(t0, t2, 0xee);
      const __m256 u2 = _mm256_shuffle_ps(t1, t3, 0x44), u3 = _mm256_shuffle_ps(t1, t3, 0xee);
      const __m256 u4 = _mm256_shuffle_ps(t4, t6, 0x44), u5 = _mm256_shuffle_ps(t4, t6, 0xee);
      const __m256 u6 = _mm256_shuffle_ps(t5, t7, 0x44), u7 = _mm256_shuffle_ps(t5, t7, 0xee);
      // Cell x + i's directions d0..d0 + 7.
      const __m256 c[8] = {_mm256_permute2f128_ps(u0, u4, 0x20), _mm256_permute2f128_ps(u1, u5, 0x20),
                           _mm256_permute2f128_ps(u2, u6, 0x20), _mm256_permute2f128_ps(u3, u7, 0x20),
                           _mm256_permute2f128_ps(u0, u4, 0x31), _mm256_permute2f128_ps(u1, u5, 0x31),
                           _mm256_permute2f128_ps(u2, u6, 0x31), _mm256_permute2f128_ps(u3, u7, 0x31)};
      for (int i = 0; i < 8; ++i) _mm256_storeu_ps(reinterpret_cast<float*>(grid + size_t(x + i) * kDirections + size_t(d0)), c[i]);
    }
    for (int d = kDirections / 8 * 8; d < kDirections; ++d)
      for (int i = 0; i < 8; ++i) grid[size_t(x + i) * kDirections + size_t(d)] = codes[size_t(d) * stride + size_t(x + i)];
  }
  transposeCodesScalar(codes, stride, n, grid, x);
}
#endif
void transposeCodes(const uint32_t* codes, size_t stride, int n, uint32_t* grid) {
#if defined(__GNUC__) && defined(__x86_64__)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return transposeCodesAvx2(codes, stride, n, grid);
#endif
  transposeCodesScalar(codes, stride, n, grid, 0);
}

// One component of glm::packSnorm4x8 without libm's roundf: clamp to [-1, 1], times 127, rounded
// half away from zero (std::round: v - trunc(v) is exact for |v| <= 127), as a byte. The scalar
// definition that snormByteV computes L lanes at a time.
[[maybe_unused]] inline uint32_t snormByte(float d) {
  const float v = std::min(std::max(d, -1.f), 1.f) * 127.f;
  const int i = int(v);
  const float f = v - float(i);
  const int rounded = i + (f >= 0.5f ? 1 : 0) - (f <= -0.5f ? 1 : 0);
  return uint32_t(rounded) & 0xffu;
}


// L lanes of GCC's vector extensions (GCC and Clang): 16 in the x86-64-v4 code, one AVX-512
// register; 8 in the AVX2 code, one register, and in the baseline, two SSE ones. Whichever, the
// same IEEE operations lane by lane as the scalar functions they mirror (snormByte,
// detail::packR11G11B10), so the same bits. With 8 lanes AVX-512 code had nothing to gain
// (docs/sweep.md); at 16 the row loops, bound by instructions, take half as many in it. 16 lanes
// in the AVX2 code took 6 times the instructions in storeCells (valgrind): kept at 8 there.
using V8f = float __attribute__((vector_size(32)));
using V8i = int32_t __attribute__((vector_size(32)));
using V8u = uint32_t __attribute__((vector_size(32)));
using V16f = float __attribute__((vector_size(64)));
using V16i = int32_t __attribute__((vector_size(64)));
using V16u = uint32_t __attribute__((vector_size(64)));
template <int L>
struct Vec;
template <>
struct Vec<8> {
  using F = V8f;
  using I = V8i;
  using U = V8u;
};
template <>
struct Vec<16> {
  using F = V16f;
  using I = V16i;
  using U = V16u;
};
// The most lanes of any code: the rows the vector loops read are padded for it.
constexpr int kLanes = 16;
static_assert(kLanes <= kRowFloats, "the level buffers' rows hold whole groups of lanes");

template <int L>
[[gnu::always_inline]] inline typename Vec<L>::F loadV(const float* p) {
  typename Vec<L>::F v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class V, class T>
[[gnu::always_inline]] inline void storeV(T* p, const V& v) {
  static_assert(sizeof(V) % sizeof(T) == 0);
  std::memcpy(p, &v, sizeof v);
}

// detail::packSmall, L lanes.
template <int kMant, int L>
[[gnu::always_inline]] inline typename Vec<L>::U packSmallV(const typename Vec<L>::F& v) {
  using VInt = typename Vec<L>::I;
  using VUint = typename Vec<L>::U;
  constexpr int kShift = 23 - kMant;
  constexpr int32_t kMax = (30 << kMant) | ((1 << kMant) - 1);
  const VUint b = std::bit_cast<VUint>(v);
  const VInt r = VInt(((b - (112u << 23)) + (1u << (kShift - 1))) >> kShift);
  const VInt clamped = r < kMax ? r : VInt{} + kMax;
  return VUint(v >= 6.103515625e-05f ? clamped : VInt{});
}
template <int L>
[[gnu::always_inline]] inline typename Vec<L>::U packR11G11B10V(const typename Vec<L>::F& r, const typename Vec<L>::F& g,
                                                               const typename Vec<L>::F& b) {
  return packSmallV<6, L>(r) | (packSmallV<6, L>(g) << 11) | (packSmallV<5, L>(b) << 22);
}

// snormByte, L lanes (a comparison's lanes are -1 where true).
template <int L>
[[gnu::always_inline]] inline typename Vec<L>::U snormByteV(const typename Vec<L>::F& d) {
  using VFloat = typename Vec<L>::F;
  using VInt = typename Vec<L>::I;
  using VUint = typename Vec<L>::U;
  const VFloat lo = d < -1.f ? VFloat{} - 1.f : d;      // std::max(d, -1)
  const VFloat hi = 1.f < lo ? VFloat{} + 1.f : lo;     // std::min(lo, 1)
  const VFloat v = hi * 127.f;
  const VInt i = __builtin_convertvector(v, VInt);  // truncates, as int(v)
  const VFloat f = v - __builtin_convertvector(i, VFloat);
  const VInt rounded = i - VInt(f >= 0.5f) + VInt(f <= -0.5f);
  return VUint(rounded) & 0xffu;
}

// One row's stored light, per direction d a row of n floats of each channel c at light[d] + c
// stride; for the down-going directions also the sun's unscattered part to take off (direct[d],
// likewise; null where the bin has none). Rows are read, and written, in whole groups of
// kLanes: each has room up to n rounded up (what lies there is computed and not used).
struct StoreRows {
  std::array<const float*, kDirections> light;
  std::array<const float*, kSwept> direct;
  size_t stride = 0;
  std::array<float, kDirections> from_x, from_y, from_z;  // unit source directions
  int first = 0, end = kDirections;  // the directions stored (bottom_up: the down-going ones first)
};

// The light grid's words for a row of n cells, in one pass over the cells kLanes at a time, the
// sums of the cell's light in registers (Sweeper::add's order: direction by direction, rgb,
// luminance, luminance times the unit source direction):
//  - each direction's stored light, less the sun's unscattered part and clamped at 0 for the
//    down-going ones (kSubtract; without it, as it is: direct_sun), packed into row d of
//    `codes` (direction-major, `code_stride` words a row; transposeCodes puts them in the grid's
//    layout);
//  - kFinish: the cells' average light (the rgb sums over 4 pi) and dominant direction (the
//    luminance-weighted direction sums over the luminance sum, 0 without light), packed
//    otherwise the 7 sums, rows of `sum_stride` (bottom_up adds to them later);
//  - kResume: the sums start from those rows (bottom_up's up-going directions), not from 0.
// Was one loop per direction for the packing and one for the sums, which loaded and stored the 7
// sums per direction, then a loop to finish: 23 % of the sweep's instructions.
#define DRTV_SWEEP_STORE_PARAMS                                                                                   \
  int n, const StoreRows& s, uint32_t* __restrict codes, size_t code_stride, float* __restrict sums, size_t sum_stride, \
      uint32_t* __restrict average, uint32_t* __restrict dominant
#define DRTV_SWEEP_STORE_ARGS n, s, codes, code_stride, sums, sum_stride, average, dominant
template <bool kSubtract, bool kFinish, bool kResume, int L>
[[gnu::always_inline]] inline void storeCellsBody(DRTV_SWEEP_STORE_PARAMS) {
  using VFloat = typename Vec<L>::F;
  const size_t stride = s.stride;
  for (int x = 0; x < n; x += L) {
    VFloat sr{}, sg{}, sb{}, sl{}, sx{}, sy{}, sz{};
    if constexpr (kResume) {
      int row = 0;
      for (VFloat* v : {&sr, &sg, &sb, &sl, &sx, &sy, &sz}) *v = loadV<L>(sums + size_t(row++) * sum_stride + size_t(x));
    }
    for (int d = s.first; d < s.end; ++d) {
      const float* light = s.light[size_t(d)] + x;
      VFloat r = loadV<L>(light), g = loadV<L>(light + stride), b = loadV<L>(light + 2 * stride);
      if (kSubtract && d < kSwept) {  // std::max(light - direct, 0)
        // Without the sun's light in this bin, light - 0 is light, bit for bit (-0 - +0 is -0).
        if (const float* direct = s.direct[size_t(d)]) {
          direct += x;
          r = r - loadV<L>(direct);
          g = g - loadV<L>(direct + stride);
          b = b - loadV<L>(direct + 2 * stride);
        }
        r = r < 0.f ? VFloat{} : r;
        g = g < 0.f ? VFloat{} : g;
        b = b < 0.f ? VFloat{} : b;
      }
      storeV(codes + size_t(d) * code_stride + size_t(x), packR11G11B10V<L>(r, g, b));
      sr += r;
      sg += g;
      sb += b;
      const VFloat l = 0.2126f * r + 0.7152f * g + 0.0722f * b;
      sl += l;
      sx += l * s.from_x[size_t(d)];
      sy += l * s.from_y[size_t(d)];
      sz += l * s.from_z[size_t(d)];
    }
    if constexpr (kFinish) {
      storeV(average + x, packR11G11B10V<L>(sr / kFourPi, sg / kFourPi, sb / kFourPi));
      const auto lit = sl > 0.f;
      const VFloat dx = lit ? sx / sl : VFloat{}, dy = lit ? sy / sl : VFloat{}, dz = lit ? sz / sl : VFloat{};
      storeV(dominant + x, snormByteV<L>(dx) | (snormByteV<L>(dy) << 8) | (snormByteV<L>(dz) << 16));
    } else {
      int row = 0;
      for (const VFloat v : {sr, sg, sb, sl, sx, sy, sz}) storeV(sums + size_t(row++) * sum_stride + size_t(x), v);
    }
  }
}
#if DRTV_SIMD_MULTIVERSION
template <bool kSubtract, bool kFinish, bool kResume>
__attribute__((target("arch=x86-64-v4"))) void storeCellsV4(DRTV_SWEEP_STORE_PARAMS) {
  storeCellsBody<kSubtract, kFinish, kResume, 16>(DRTV_SWEEP_STORE_ARGS);
}
template <bool kSubtract, bool kFinish, bool kResume>
__attribute__((target("avx2"))) void storeCellsAvx2(DRTV_SWEEP_STORE_PARAMS) {
  storeCellsBody<kSubtract, kFinish, kResume, 8>(DRTV_SWEEP_STORE_ARGS);
}
#endif
template <bool kSubtract, bool kFinish, bool kResume = false>
void storeCells(DRTV_SWEEP_STORE_PARAMS) {
#if DRTV_SIMD_MULTIVERSION
  switch (isa()) {
    case Isa::kV4: return storeCellsV4<kSubtract, kFinish, kResume>(DRTV_SWEEP_STORE_ARGS);
    case Isa::kAvx2: return storeCellsAvx2<kSubtract, kFinish, kResume>(DRTV_SWEEP_STORE_ARGS);
    case Isa::kBase: break;
  }
#endif
  storeCellsBody<kSubtract, kFinish, kResume, 8>(DRTV_SWEEP_STORE_ARGS);
}
#undef DRTV_SWEEP_STORE_PARAMS
#undef DRTV_SWEEP_STORE_ARGS

// A row's pass-through where it is 0 or 1: 1 in a clear cell (sigma 0), 0 in a full one (sigma inf);
// the cells of fractional density are patched in after. Sweeper's own code is the baseline's (SSE):
// its row loops are clones like these so that the v4 code runs them 16 floats at a time.
DRTV_SIMD_CLONES void clearOrFull(int n, const float* __restrict sigma, float* __restrict out) {
  for (int x = 0; x < n; ++x) out[x] = sigma[x] == 0.f ? 1.f : 0.f;
}

// A row of n densities: their optical depths per cell length where no log is needed (0 for clear
// cells, inf for full ones; 0 for now in the cells of fractional density), and how many cells
// have material, fractional density, or a density outside [0, 1] (NaN too).
struct DensityRow {
  int material = 0, fractional = 0, outside = 0;
};
DRTV_SIMD_CLONES DensityRow opticalDepthRow(int n, const float* __restrict d, float* __restrict s) {
  int material = 0, fractional = 0, outside = 0;
  for (int x = 0; x < n; ++x) {  // as ints and &: with && GCC did not vectorise the loop
    const float v = d[x];
    const int some = v > 0.f ? 1 : 0, part = v < 1.f ? 1 : 0, in = (v >= 0.f ? 1 : 0) & (v <= 1.f ? 1 : 0);
    material += some;
    fractional += some & part;
    outside += 1 - in;
    s[x] = v >= 1.f ? kInf : 0.f;
  }
  return {material, fractional, outside};
}

#if defined(__GNUC__) && !defined(__clang__)
#define DRTV_SWEEP_NO_MEMCPY_IDIOM __attribute__((optimize("no-tree-loop-distribute-patterns")))
#else
#define DRTV_SWEEP_NO_MEMCPY_IDIOM
#endif

// `rows` rows of n floats from src (rows src_stride apart; 0: the same row each time) to dst (rows
// dst_stride apart). A row's span is short (tens of floats) and copied into 6-57 rows: one memcpy
// call per row, with its set-up, was 3 % of a re-sweep; GCC would turn this loop back into those
// calls (-ftree-loop-distribute-patterns), hence the attribute.
DRTV_SIMD_CLONES DRTV_SWEEP_NO_MEMCPY_IDIOM void copyRows(int rows, int n, const float* __restrict src, size_t src_stride,
                                                         float* __restrict dst, size_t dst_stride) {
  for (int r = 0; r < rows; ++r, src += src_stride, dst += dst_stride)
    for (int x = 0; x < n; ++x) dst[x] = src[x];
}

// (1 + tau) / 2 and (1 - tau) / 2 of a row's cells (Sweeper::interactRow).
DRTV_SIMD_CLONES void halfSums(int n, const float* __restrict tau, float* __restrict fa, float* __restrict fb) {
  for (int m = 0; m < n; ++m) {
    fa[m] = 0.5f * (1.f + tau[m]);
    fb[m] = 0.5f * (1.f - tau[m]);
  }
}

// n RGB triples (glm::vec3, 3 floats each) into 3 rows. Through glm's operator[] GCC switched on
// the channel per element.
DRTV_SIMD_CLONES void splitRgb(int n, const float* __restrict rgb, float* __restrict r, float* __restrict g, float* __restrict b) {
  for (int m = 0; m < n; ++m) {
    r[m] = rgb[3 * m];
    g[m] = rgb[3 * m + 1];
    b[m] = rgb[3 * m + 2];
  }
}

// The bottom-up pass in a row of n cells, for one up-going direction: its gathered light v (3 rows,
// channels `stride` apart) passes the cell as T (row t) plus what the cell reflects up (e, 3 rows
// of `e_stride`), and leaves as v T + e (into v); what is stored is v sqrt(T) + e / 2 (rows
// `stored`, channels `stride` apart). As Sweeper::bottomUp did it cell by cell.
DRTV_SIMD_CLONES void upCells(int n, float* __restrict v, size_t stride, const float* __restrict t, const float* __restrict st,
                               const float* __restrict e, size_t e_stride, float* __restrict stored) {
  for (size_t c = 0; c < 3; ++c) {
    float* __restrict vc = v + c * stride;
    const float* __restrict ec = e + c * e_stride;
    float* __restrict sc = stored + c * stride;
    for (int x = 0; x < n; ++x) {
      const float in = vc[x];
      vc[x] = in * t[x] + ec[x];
      sc[x] = in * st[x] + 0.5f * ec[x];
    }
  }
}

// One direction's gather along a row of n cells, its 3 channels at once (channel c's rows are
// c * stride after channel 0's): a[x] = the sum over the taps t, in tap order (the reference's
// order of accumulation), of w_t[x] s[t][x], where
// w_t[x] is the tap's weight times the product, in order, of its crossed material cells' factors
// (rows f[t][0..nf[t]), or the weight alone (all of them without kVarying). Rows are read in whole
// groups of kLanes (room up to n rounded up); the stores stop at n.
struct TapRows {
  std::array<float, kTaps> w{};
  std::array<int, kTaps> nf{};
  std::array<std::array<const float*, kMaxCrossed>, kTaps> f{};
  std::array<const float*, kTaps> s{};
  float* a = nullptr;
  size_t stride = 0;
};

template <int L>
[[gnu::always_inline]] inline typename Vec<L>::F splatV(float v) {
  typename Vec<L>::F r;
  for (int i = 0; i < L; ++i) r[i] = v;
  return r;
}

// Tap t's weights at cells x..x + L - 1 (gatherRow).
template <int L>
[[gnu::always_inline]] inline typename Vec<L>::F tapWeight(const TapRows& g, int nf, int t, int x, const typename Vec<L>::F& w) {
  if (nf == 0) return w;
  const std::array<const float*, kMaxCrossed>& f = g.f[size_t(t)];
  typename Vec<L>::F p = loadV<L>(f[0] + x);
  for (int c = 1; c < nf; ++c) p = p * loadV<L>(f[size_t(c)] + x);
  return w * p;
}

// The weights' rows of the first version: a row of each crossed factor, multiplied in, then the
// tap's weight; one loop per tap and channel: with 3 channels and the weights in registers, 8 %
// of the sweep's instructions go.
template <bool kVarying, int L>
[[gnu::always_inline]] inline void gatherRowBody(int n, const TapRows& g) {
  using VFloat = typename Vec<L>::F;
  const float *s0 = g.s[0], *s1 = g.s[1], *s2 = g.s[2], *s3 = g.s[3], *s4 = g.s[4];
  float* __restrict a = g.a;
  const size_t stride = g.stride;
  // Copies: the stores through `a` could alias g's weights for all the compiler knows.
  const VFloat c0 = splatV<L>(g.w[0]), c1 = splatV<L>(g.w[1]), c2 = splatV<L>(g.w[2]), c3 = splatV<L>(g.w[3]), c4 = splatV<L>(g.w[4]);
  const int nf0 = g.nf[0], nf1 = g.nf[1], nf2 = g.nf[2], nf3 = g.nf[3], nf4 = g.nf[4];
  for (int x = 0; x < n; x += L) {
    const VFloat w[kTaps] = {kVarying ? tapWeight<L>(g, nf0, 0, x, c0) : c0, kVarying ? tapWeight<L>(g, nf1, 1, x, c1) : c1,
                          kVarying ? tapWeight<L>(g, nf2, 2, x, c2) : c2, kVarying ? tapWeight<L>(g, nf3, 3, x, c3) : c3,
                          kVarying ? tapWeight<L>(g, nf4, 4, x, c4) : c4};
    for (size_t c = 0; c < 3; ++c) {
      const size_t at = c * stride + size_t(x);
      const VFloat v = w[0] * loadV<L>(s0 + at) + w[1] * loadV<L>(s1 + at) + w[2] * loadV<L>(s2 + at) + w[3] * loadV<L>(s3 + at) + w[4] * loadV<L>(s4 + at);
      if (x + L <= n) {
        storeV(a + at, v);
      } else {
        float tail[L];
        storeV(tail, v);
        std::copy_n(tail, n - x, a + at);
      }
    }
  }
}
#if DRTV_SIMD_MULTIVERSION
template <bool kVarying>
__attribute__((target("arch=x86-64-v4"))) void gatherRowV4(int n, const TapRows& g) {
  gatherRowBody<kVarying, 16>(n, g);
}
template <bool kVarying>
__attribute__((target("avx2"))) void gatherRowAvx2(int n, const TapRows& g) {
  gatherRowBody<kVarying, 8>(n, g);
}
#endif
template <bool kVarying>
void gatherRow(int n, const TapRows& g) {
#if DRTV_SIMD_MULTIVERSION
  switch (isa()) {
    case Isa::kV4: return gatherRowV4<kVarying>(n, g);
    case Isa::kAvx2: return gatherRowAvx2<kVarying>(n, g);
    case Isa::kBase: break;
  }
#endif
  gatherRowBody<kVarying, 8>(n, g);
}

// The batch's rows for the reflection (Sweeper::interactRow), per cell of a span: the cell's
// pass-through tau and (1 +- tau) / 2, its reflectance, and the sums of what it stops (sum, and q:
// q[3 axis + channel] = sum_i q_i travel_i).
struct ReflectionRows {
  const float *tau, *fa, *fb;
  const float* rho[3];
  float* sum[3];
  float* q[9];
};

// Adds what one direction loses in each cell of the span, its light I (rows in_*) times (1 - T)
// (row t), normalised by the direction's norm, to the sums.
DRTV_SIMD_CLONES void addStopped(int n, const ReflectionRows& w, const float* __restrict in_r, const float* __restrict in_g,
                                  const float* __restrict in_b, const float* __restrict t, float cos_sum, float ux, float uy, float uz) {
  const float* __restrict tau = w.tau;
  float *__restrict sr = w.sum[0], *__restrict sg = w.sum[1], *__restrict sb = w.sum[2];
  float *__restrict qxr = w.q[0], *__restrict qxg = w.q[1], *__restrict qxb = w.q[2];
  float *__restrict qyr = w.q[3], *__restrict qyg = w.q[4], *__restrict qyb = w.q[5];
  float *__restrict qzr = w.q[6], *__restrict qzg = w.q[7], *__restrict qzb = w.q[8];
#pragma GCC ivdep
  for (int m = 0; m < n; ++m) {
    const float norm = kFourPi - 0.5f * (1.f - tau[m]) * (kFourPi + cos_sum);
    const float share = (1.f - t[m]) / norm;
    const float qr = in_r[m] * share, qg = in_g[m] * share, qb = in_b[m] * share;
    sr[m] += qr;
    sg[m] += qg;
    sb[m] += qb;
    qxr[m] += qr * ux;
    qxg[m] += qg * ux;
    qxb[m] += qb * ux;
    qyr[m] += qr * uy;
    qyg[m] += qg * uy;
    qyb[m] += qb * uy;
    qzr[m] += qr * uz;
    qzg[m] += qg * uz;
    qzb[m] += qb * uz;
  }
}

// The light reflected into outgoing direction (ux, uy, uz) of solid angle omega, in channel c of
// cell m: rho Omega (fa sum - fb q . travel).
#define DRTV_SWEEP_REFLECTED(c)                                                       \
  ((rho##c[m] * omega) * (fa[m] * s##c[m] - fb[m] * (qx##c[m] * ux + qy##c[m] * uy + qz##c[m] * uz)))

// A down-going direction's light in each cell of the span: what it stores (I sqrt(T) + reflected
// / 2, replacing its gathered light in rows io_*) and what it sends on (I T + reflected, rows l*).
DRTV_SIMD_CLONES void reflectDown(int n, const ReflectionRows& w, float ux, float uy, float uz, float omega, const float* __restrict t,
                                   const float* __restrict st, float* __restrict io_r, float* __restrict io_g, float* __restrict io_b,
                                   float* __restrict lr, float* __restrict lg, float* __restrict lb) {
  const float *__restrict fa = w.fa, *__restrict fb = w.fb;
  const float *__restrict rhor = w.rho[0], *__restrict rhog = w.rho[1], *__restrict rhob = w.rho[2];
  const float *__restrict sr = w.sum[0], *__restrict sg = w.sum[1], *__restrict sb = w.sum[2];
  const float *__restrict qxr = w.q[0], *__restrict qxg = w.q[1], *__restrict qxb = w.q[2];
  const float *__restrict qyr = w.q[3], *__restrict qyg = w.q[4], *__restrict qyb = w.q[5];
  const float *__restrict qzr = w.q[6], *__restrict qzg = w.q[7], *__restrict qzb = w.q[8];
#pragma GCC ivdep
  for (int m = 0; m < n; ++m) {
    const float ref_r = DRTV_SWEEP_REFLECTED(r), ref_g = DRTV_SWEEP_REFLECTED(g), ref_b = DRTV_SWEEP_REFLECTED(b);
    const float ir = io_r[m], ig = io_g[m], ib = io_b[m];
    lr[m] = ir * t[m] + ref_r;
    lg[m] = ig * t[m] + ref_g;
    lb[m] = ib * t[m] + ref_b;
    io_r[m] = ir * st[m] + 0.5f * ref_r;
    io_g[m] = ig * st[m] + 0.5f * ref_g;
    io_b[m] = ib * st[m] + 0.5f * ref_b;
  }
}

// An up-going direction's reflected light in each cell of the span, into rows e*.
DRTV_SIMD_CLONES void reflectUp(int n, const ReflectionRows& w, float ux, float uy, float uz, float omega, float* __restrict er,
                                 float* __restrict eg, float* __restrict eb) {
  const float *__restrict fa = w.fa, *__restrict fb = w.fb;
  const float *__restrict rhor = w.rho[0], *__restrict rhog = w.rho[1], *__restrict rhob = w.rho[2];
  const float *__restrict sr = w.sum[0], *__restrict sg = w.sum[1], *__restrict sb = w.sum[2];
  const float *__restrict qxr = w.q[0], *__restrict qxg = w.q[1], *__restrict qxb = w.q[2];
  const float *__restrict qyr = w.q[3], *__restrict qyg = w.q[4], *__restrict qyb = w.q[5];
  const float *__restrict qzr = w.q[6], *__restrict qzg = w.q[7], *__restrict qzb = w.q[8];
#pragma GCC ivdep
  for (int m = 0; m < n; ++m) {
    er[m] = DRTV_SWEEP_REFLECTED(r);
    eg[m] = DRTV_SWEEP_REFLECTED(g);
    eb[m] = DRTV_SWEEP_REFLECTED(b);
  }
}
#undef DRTV_SWEEP_REFLECTED

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
