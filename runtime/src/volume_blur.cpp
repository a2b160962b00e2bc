// volume_blur.cpp — the volume's 3x3x3 [1 2 1] blur (volume.h, VolumeOptions::blur; talk slide 60
// [1]): blurBox, the two forms it takes for whole rows and for thin boxes, and their row kernels.
#include "drtv/runtime/volume.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <span>
#include <type_traits>
#include <vector>

#include "drtv/formats/error.h"
#include "simd_clones.h"
#include "toroidal.h"

namespace drtv::runtime {
namespace {

using detail::floorDiv;
using detail::floorMod;

// Boxes at most this many texels wide in x are blurred with y as the fast axis (see blurBox).
constexpr int kThinBlurX = 4;
// Box rows blurred together (blurBox): a strip's buffers fit in L1.
constexpr int kBlurStripRows = 8;
// The same from the cell source (blurWholeRowsFromCells), whose buffers are a quarter the size; a
// strip's first and last rows of cells are also its neighbours'.
constexpr int kCellStripRows = 32;

// The blur's row kernels, on 16-bit lanes (sums stay below 64 * 255), written so that they
// vectorise: restrict pointers, no widening to int. They are compiled for AVX-512 and AVX2 as well
// as the baseline and picked at load time (DRTV_SIMD_CLONES, simd_clones.h): the baseline's 8
// lanes made the blur 3x a plain refill.
DRTV_SIMD_CLONES void blurTap3(const uint8_t* __restrict m, uint16_t* __restrict out, int lo, int hi) {
  for (int i = lo; i < hi; ++i) out[i] = uint16_t(uint16_t(m[i - 4]) + uint16_t(2 * m[i]) + uint16_t(m[i + 4]));
}
DRTV_SIMD_CLONES void blurRows3(const uint16_t* __restrict r0, const uint16_t* __restrict r1, const uint16_t* __restrict r2,
               uint16_t* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = uint16_t(r0[i] + uint16_t(2 * r1[i]) + r2[i]);
}
// The same taps for the thin-x blur, whose rows run along y: bytes in, and 16-bit sums in.
DRTV_SIMD_CLONES void blurRows3Bytes(const uint8_t* __restrict r0, const uint8_t* __restrict r1, const uint8_t* __restrict r2,
                    uint16_t* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = uint16_t(uint16_t(r0[i]) + uint16_t(2 * r1[i]) + uint16_t(r2[i]));
}
DRTV_SIMD_CLONES void blurTap3Wide(const uint16_t* __restrict m, uint16_t* __restrict out, int lo, int hi) {
  for (int i = lo; i < hi; ++i) out[i] = uint16_t(m[i - 4] + uint16_t(2 * m[i]) + m[i + 4]);
}
// The x pass and the rounding in one (blurWholeRows): m holds the z and y passes' sums.
DRTV_SIMD_CLONES void blurTap3Finish(const uint16_t* __restrict m, uint8_t* __restrict out, int lo, int hi) {
  for (int i = lo; i < hi; ++i) out[i] = uint8_t(uint16_t(m[i - 4] + uint16_t(2 * m[i]) + m[i + 4] + 32) >> 6);
}
// blurTap3Finish for chosen texels of `rows` rows of `stride` lanes (blurWholeRows's patches):
// bytes [to, to + 4) of each row from the lanes at offsets left, centre and right. Each is one
// 8-lane vector sum of two texels' lanes (the second texel's are dropped; every offset is of a
// column before the row's last, so its successor is in the row): a few instructions, where
// twelve scalar loads and stores per texel (this path's first form) were 15 % of a blurred refill. Cloned: the baseline
// lacks the byte-to-word and word-to-byte moves.
struct BlurPatch {
  int to, left, centre, right;
};
using BlurBytes8 = uint8_t __attribute__((vector_size(8)));
using BlurLanes8 = uint16_t __attribute__((vector_size(16)));
[[gnu::always_inline]] inline void blurFinishPatch(const uint16_t* __restrict m, uint8_t* __restrict out, const BlurPatch& p) {
  BlurLanes8 l, c, x;
  std::memcpy(&l, m + p.left, sizeof l), std::memcpy(&c, m + p.centre, sizeof c), std::memcpy(&x, m + p.right, sizeof x);
  const BlurBytes8 bytes = __builtin_convertvector((l + c + c + x + 32) >> 6, BlurBytes8);
  std::memcpy(out + p.to, &bytes, 4);
}
DRTV_SIMD_CLONES void blurFinishPatches(const uint16_t* __restrict m, uint8_t* __restrict out, int rows, int stride,
                                        const BlurPatch* __restrict patches, int count) {
  for (int r = 0; r < rows; ++r, m += stride, out += stride)
    for (int p = 0; p < count; ++p) blurFinishPatch(m, out, patches[p]);
}
// The x pass and the rounding from a row of cells (four 16-bit lanes each, the z and y passes'
// sums; blurWholeRowsFromCells): cell i's two texels, bytes [8 i, 8 i + 8) of `out`, are
// (y[i - 1] + 3 y[i] + 32) >> 6 and (3 y[i] + y[i + 1] + 32) >> 6. Reads cells -1 to count.
// Written with vectors of cells: a plain loop did not vectorise.
using BlurLanes16 = uint16_t __attribute__((vector_size(32)));
using BlurBytes32 = uint8_t __attribute__((vector_size(32)));
using BlurLanes32 = uint16_t __attribute__((vector_size(64)));
using BlurBytes64 = uint8_t __attribute__((vector_size(64)));
// Cells [i, i + 4 V) of blurCellsFinish, V = 1 or 2 (vectors of 32 or 64 bytes: AVX-512 takes
// the eight cells in one register, AVX2 in two).
template <class Lanes, class Bytes>
[[gnu::always_inline]] inline void blurCellsFinishAt(const uint16_t* __restrict y, uint8_t* __restrict out, int i) {
  Lanes l, c, r;
  std::memcpy(&l, y + 4 * i - 4, sizeof l), std::memcpy(&c, y + 4 * i, sizeof c), std::memcpy(&r, y + 4 * i + 4, sizeof r);
  const Lanes t = c + c + c + 32;
  const Lanes lo = (l + t) >> 6, hi = (t + r) >> 6;
  // The low bytes of lo's and hi's lanes, alternating texel by texel (four bytes) within each
  // 128-bit quarter. Interleaving lo and hi as 16-bit lanes first and packing after took three
  // times as many shuffles, across lanes.
  const auto lo8 = reinterpret_cast<Bytes>(lo), hi8 = reinterpret_cast<Bytes>(hi);
  // One in-lane byte shuffle of each (the same indices: texel k's bytes at 8 k and 8 k + 4 of
  // its half), then lo's or hi's by texel: a blend. (Two-source shuffles became vpermt2w.)
  Bytes a, b;
  if constexpr (sizeof(Bytes) == 32) {
    a = __builtin_shufflevector(lo8, lo8, 0, 2, 4, 6, 0, 2, 4, 6, 8, 10, 12, 14, 8, 10, 12, 14, 16, 18, 20, 22, 16, 18, 20, 22, 24, 26, 28, 30, 24, 26, 28, 30);
    b = __builtin_shufflevector(hi8, hi8, 0, 2, 4, 6, 0, 2, 4, 6, 8, 10, 12, 14, 8, 10, 12, 14, 16, 18, 20, 22, 16, 18, 20, 22, 24, 26, 28, 30, 24, 26, 28, 30);
  } else {
    a = __builtin_shufflevector(lo8, lo8, 0, 2, 4, 6, 0, 2, 4, 6, 8, 10, 12, 14, 8, 10, 12, 14, 16, 18, 20, 22, 16, 18, 20, 22, 24, 26, 28, 30, 24, 26, 28, 30, 32, 34, 36, 38, 32, 34, 36, 38, 40, 42, 44, 46, 40, 42, 44, 46, 48, 50, 52, 54, 48, 50, 52, 54, 56, 58, 60, 62, 56, 58, 60, 62);
    b = __builtin_shufflevector(hi8, hi8, 0, 2, 4, 6, 0, 2, 4, 6, 8, 10, 12, 14, 8, 10, 12, 14, 16, 18, 20, 22, 16, 18, 20, 22, 24, 26, 28, 30, 24, 26, 28, 30, 32, 34, 36, 38, 32, 34, 36, 38, 40, 42, 44, 46, 40, 42, 44, 46, 48, 50, 52, 54, 48, 50, 52, 54, 56, 58, 60, 62, 56, 58, 60, 62);
  }
  Bytes odd{};  // 0xff where the second texel of a cell goes: bytes 4-7 of every 8
  for (size_t k = 0; k < sizeof(Bytes); ++k) odd[k] = (k & 4) ? 0xff : 0;
  const Bytes bytes = (a & ~odd) | (b & odd);
  std::memcpy(out + 8 * i, &bytes, sizeof bytes);
}
template <int kVectorBytes>
[[gnu::always_inline]] inline void blurCellsFinish(const uint16_t* __restrict y, uint8_t* __restrict out, int count) {
  // Vectors of kVectorBytes / 8 cells; the last one ends at `count` and overlaps the one before
  // (the same bytes twice): a scalar remainder per run cost as much as the vectors.
  if constexpr (kVectorBytes == 64) {
    if (count >= 8) {
      for (int i = 0; i < count - 8; i += 8) blurCellsFinishAt<BlurLanes32, BlurBytes64>(y, out, i);
      return blurCellsFinishAt<BlurLanes32, BlurBytes64>(y, out, count - 8);
    }
  }
  if (count >= 4) {
    for (int i = 0; i < count - 4; i += 4) blurCellsFinishAt<BlurLanes16, BlurBytes32>(y, out, i);
    return blurCellsFinishAt<BlurLanes16, BlurBytes32>(y, out, count - 4);
  }
  for (int i = 0; i < count; ++i)
    for (int l = 0; l < 4; ++l) {
      const int k = 4 * i + l, t = 3 * y[k] + 32;
      out[8 * i + l] = uint8_t((y[k - 4] + t) >> 6), out[8 * i + 4 + l] = uint8_t((t + y[k + 4]) >> 6);
    }
}
// A row (or a cell's two rows) of texels from rows of cells (blurWholeRowsFromCells): the runs
// (blurCellsFinish) and then the patches, in one call per row pair (the calls through the clones'
// dispatch were a tenth of a blurred refill when each run and the patches were one).
struct CellRun {
  int first, cells, lane;  // from storage column `first` (its cell's first texel), `cells` cells from lane `lane`
};
template <int kVectorBytes>
[[gnu::always_inline]] inline void blurCellRowsOf(const uint16_t* __restrict y, int y_stride, uint8_t* const* out_rows, int rows,
                                                  const CellRun* __restrict runs, int run_count, const BlurPatch* __restrict patches,
                                                  int patch_count) {
  for (int r = 0; r < rows; ++r, y += y_stride) {
    uint8_t* __restrict out = out_rows[r];
    for (int k = 0; k < run_count; ++k) blurCellsFinish<kVectorBytes>(y + runs[k].lane, out + 4 * runs[k].first, runs[k].cells);
    for (int p = 0; p < patch_count; ++p) blurFinishPatch(y, out, patches[p]);
  }
}
// The kernels of the blur from cells, one version per target as relight_kernels.cpp's
// (DRTV_SIMD_CLONES gives every clone the same vectors): 64-byte vectors with AVX-512, 32-byte
// ones with AVX2 and the baseline, where GCC split the 64-byte shuffles into byte inserts.
#if DRTV_SIMD_MULTIVERSION
#define DRTV_CELL_KERNEL(name, params, args)                                                      \
  __attribute__((target("arch=x86-64-v4"))) void name params { name##Of<64> args; }             \
  __attribute__((target("arch=x86-64-v3"))) void name params { name##Of<32> args; }             \
  __attribute__((target("default"))) void name params { name##Of<32> args; }
#else
#define DRTV_CELL_KERNEL(name, params, args) \
  void name params { name##Of<32> args; }
#endif
DRTV_CELL_KERNEL(blurCellRows,
                 (const uint16_t* y, int y_stride, uint8_t* const* out_rows, int rows, const CellRun* runs, int run_count,
                  const BlurPatch* patches, int patch_count),
                 (y, y_stride, out_rows, rows, runs, run_count, patches, patch_count))


// The y pass for a cell's two rows of texels: the first's taps are the cell above and its own
// cell twice, the second's its own cell twice and the cell below. n lanes: a multiple of 32
// (whole rows of cells, whose period is a multiple of 8).
template <int kVectorBytes>
[[gnu::always_inline]] inline void blurCellsYPairOf(const uint16_t* __restrict up, const uint16_t* __restrict mid,
                                                    const uint16_t* __restrict down, uint16_t* __restrict first,
                                                    uint16_t* __restrict second, int n) {
  using Lanes = std::conditional_t<kVectorBytes == 64, BlurLanes32, BlurLanes16>;
  constexpr int kLanes = kVectorBytes / 2;
  for (int i = 0; i < n; i += kLanes) {
    Lanes u, m, d;
    std::memcpy(&u, up + i, sizeof u), std::memcpy(&m, mid + i, sizeof m), std::memcpy(&d, down + i, sizeof d);
    const Lanes t = m + m + m, a = u + t, b = t + d;
    std::memcpy(first + i, &a, sizeof a), std::memcpy(second + i, &b, sizeof b);
  }
}
DRTV_CELL_KERNEL(blurCellsYPair,
                 (const uint16_t* up, const uint16_t* mid, const uint16_t* down, uint16_t* first, uint16_t* second, int n),
                 (up, mid, down, first, second, n))
#undef DRTV_CELL_KERNEL
// Weights sum to 64: round half up, back to a byte.
DRTV_SIMD_CLONES void blurFinish(const uint16_t* __restrict r0, const uint16_t* __restrict r1, const uint16_t* __restrict r2,
                uint8_t* __restrict out, int n) {
  for (int i = 0; i < n; ++i) out[i] = uint8_t(uint16_t(r0[i] + uint16_t(2 * r1[i]) + r2[i] + 32) >> 6);
}

// The duplicated row and layer of box rows [y0, y1) of layer tz just written whole into `dst`
// (mirrorBoundary's y and z; the whole-row blurs write x's duplicated column themselves). sy: the
// storage row of each apron row, oy: the box's first row in the apron.
void mirrorWholeRows(uint32_t* dst, const glm::ivec3& n, size_t row_stride, size_t layer_stride, const int* sy, int oy, int y0, int y1,
                     int tz) {
  auto row = [&](int ry, int rz) { return dst + size_t(rz) * layer_stride + size_t(ry) * row_stride; };
  for (int y = y0; y < y1; ++y) {
    const int ty = sy[oy + y];
    if (ty == 0) std::memcpy(row(n.y, tz), row(0, tz), row_stride * 4);
    if (tz == 0) std::memcpy(row(ty, n.z), row(ty, 0), row_stride * 4);
    if (ty == 0 && tz == 0) std::memcpy(row(n.y, n.z), row(0, 0), row_stride * 4);
  }
}

}  // namespace

void Volume::blurBox(glm::ivec3 g0, glm::ivec3 g1) {
  const glm::ivec3 n = period();
  g0 = glm::max(g0, origin_);
  g1 = glm::min(g1, origin_ + n);
  const glm::ivec3 b = g1 - g0;
  if (b.x <= 0 || b.y <= 0 || b.z <= 0) return;
  // The apron: one texel around the box, inside the covered range. Clamping a neighbour index
  // into the apron is the same as clamping it into the range (see volume.h: edges repeat).
  const glm::ivec3 a0 = glm::max(g0 - 1, origin_), a1 = glm::min(g1 + 1, origin_ + n);
  const glm::ivec3 a = a1 - a0;
  if (b.x <= kThinBlurX) return blurThinX(g0, b, a0, a);
  if (b.x == n.x) return blurWholeRows(g0, b, a0, a);
  // Storage index per apron column, row and layer, computed once (no per-texel modulo).
  thread_local std::vector<int> sx, sy, sz;
  sx.resize(a.x), sy.resize(a.y), sz.resize(a.z);
  for (int x = 0; x < a.x; ++x) sx[x] = floorMod(a0.x + x, n.x);
  for (int y = 0; y < a.y; ++y) sy[y] = floorMod(a0.y + y, n.y);
  for (int z = 0; z < a.z; ++z) sz[z] = floorMod(a0.z + z, n.z);
  // Where the apron's unblurred texels are read (source_: texels, or cells).
  thread_local std::vector<size_t> src_x, src_y, src_z;
  sourceOffsets(a0, a, src_x, src_y, src_z);
  const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
  // Columns [0, apron_run) of the apron and [0, box_run) of the box are contiguous in storage; the
  // rest (if any) continues from storage column 0.
  int apron_run = 1;
  while (apron_run < a.x && sx[apron_run] == sx[apron_run - 1] + 1) ++apron_run;
  const int ox0 = g0.x - a0.x;
  int box_run = 1;
  while (box_run < b.x && sx[ox0 + box_run] == sx[ox0 + box_run - 1] + 1) ++box_run;
  // Strips of kBlurStripRows box rows at a time, and in each strip one layer at a time: a layer's
  // x and y passes go into a ring of three blurred layers, and the z pass combines the ring as
  // soon as it holds the layers an output layer needs. A strip's working set (~30 KB) stays in
  // L1; whole layers (~330 KB) ran at L2's bandwidth, and whole-volume passes streamed ~10 MB.
  // Every pass runs over a strip as one run of lanes, apron columns included (rows of W lanes in
  // every buffer): per-row calls left a scalar remainder of up to 63 of a row's 380 lanes. Lanes
  // of apron columns that a pass computes across a row's end are never read for a box texel; the
  // box's own edge columns, where the apron has no column beyond them, are patched with their
  // clamped taps.
  const int ox = g0.x - a0.x, oy = g0.y - a0.y, oz = g0.z - a0.z;  // the box inside the apron
  const int W = 4 * a.x;                                            // lanes per row, every buffer
  const size_t strip_in = size_t(W) * (kBlurStripRows + 2), strip_out = size_t(W) * kBlurStripRows;
  // Bytes are blurred as 16-bit sums on the four interleaved lanes of a texel (tap offset +-4
  // bytes in x), in plain loops over arrays that the compiler vectorises.
  thread_local std::vector<uint8_t> src, blurred;
  thread_local std::vector<uint16_t> bx, ring;
  src.resize(strip_in), bx.resize(strip_in), ring.resize(3 * strip_out), blurred.resize(strip_out);
  const bool clamp_first = ox == 0, clamp_last = ox + b.x == a.x;  // a box edge column without apron
  for (int c = 0; c < 3; ++c) {
    const uint32_t* in = source_[c].data();
    uint32_t* dst = texels_[c].data();
    for (int y0 = 0; y0 < b.y; y0 += kBlurStripRows) {
      const int y1 = std::min(y0 + kBlurStripRows, b.y);
      const int r0 = std::max(oy + y0 - 1, 0), r1 = std::min(oy + y1 + 1, a.y);  // apron rows the strip reads
      const int rn = r1 - r0;
      int ring_z[3] = {-1, -1, -1};  // the apron layer each ring slot holds
      auto layer = [&](int zi) -> const uint16_t* {
        uint16_t* out_layer = &ring[size_t(zi % 3) * strip_out];
        if (ring_z[zi % 3] == zi) return out_layer;
        ring_z[zi % 3] = zi;
        for (int r = 0; r < rn; ++r) {
          const uint32_t* row = in + src_z[size_t(zi)] + src_y[size_t(r0 + r)];
          uint8_t* out = &src[size_t(r) * W];
          if (cell_source_) {
            for (int x = 0; x < a.x; ++x) std::memcpy(out + 4 * x, row + src_x[size_t(x)], 4);
            continue;
          }
          // sx runs contiguously up to the storage wrap: at most two copies.
          std::memcpy(out, row + sx[0], size_t(apron_run) * 4);
          if (apron_run < a.x) std::memcpy(out + 4 * apron_run, row + sx[apron_run], size_t(a.x - apron_run) * 4);
        }
        // x: [4, n - 4) has both neighbours in the strip; only the box's clamped edge columns differ.
        blurTap3(src.data(), bx.data(), 4, rn * W - 4);
        for (int r = 0; r < rn; ++r) {
          const uint8_t* q = &src[size_t(r) * W];
          uint16_t* o = &bx[size_t(r) * W];
          for (int l = 0; l < 4; ++l) {
            if (clamp_first) o[l] = uint16_t(3 * q[l] + q[4 + l]);
            if (clamp_last) o[W - 4 + l] = uint16_t(q[W - 8 + l] + 3 * q[W - 4 + l]);
          }
        }
        // y: box rows [y0, y1); only the apron's first and last rows clamp.
        auto at = [&](int apron_row) { return &bx[size_t(apron_row - r0) * W]; };
        const int first = oy + y0 == 0 ? y0 + 1 : y0, last = oy + y1 == a.y ? y1 - 1 : y1;
        if (first > y0) blurRows3(at(0), at(0), at(std::min(1, a.y - 1)), out_layer, W);
        if (last > first)
          blurRows3(at(oy + first - 1), at(oy + first), at(oy + first + 1), &out_layer[size_t(first - y0) * W], (last - first) * W);
        if (last < y1 && last >= first)
          blurRows3(at(std::max(oy + last - 1, 0)), at(oy + last), at(oy + last), &out_layer[size_t(last - y0) * W], W);
        return out_layer;
      };
      for (int z = 0; z < b.z; ++z) {
        const int gz = oz + z;
        const uint16_t* l0 = layer(std::max(gz - 1, 0));
        const uint16_t* l1 = layer(gz);
        const uint16_t* l2 = layer(std::min(gz + 1, a.z - 1));
        blurFinish(l0, l1, l2, blurred.data(), (y1 - y0) * W);
        const int tz = sz[gz];
        for (int y = y0; y < y1; ++y) {
          const uint8_t* br = &blurred[size_t(y - y0) * W + 4 * size_t(ox)];
          uint32_t* row = dst + tz * layer_stride + sy[oy + y] * row_stride;
          std::memcpy(row + sx[ox], br, size_t(box_run) * 4);
          if (box_run < b.x) std::memcpy(row + sx[ox + box_run], br + 4 * box_run, size_t(b.x - box_run) * 4);
        }
      }
    }
    mirrorBoundary(dst, std::span(sx).subspan(size_t(ox), size_t(b.x)), std::span(sy).subspan(size_t(oy), size_t(b.y)),
                   std::span(sz).subspan(size_t(oz), size_t(b.z)));
  }
}

// blurBox for a box of whole rows (b.x == n.x, so the apron is the box in x): every rebuild,
// advanceRebuild's layers, a z or y scroll's slabs. It runs in storage order, z first: per output
// layer, strip of kBlurStripRows rows and channel, the z pass reads the three source layers' rows
// where they lie (bytes in, 16-bit sums out), the y pass combines rows, and the x pass with the
// rounding writes the bytes straight into the toroidal rows, duplicated column included. Nothing
// is copied in or out (copying rows out and back was ~20 % of a blurred refill in blurBox's strip
// order, the separate mirror ~6 %), and no ring of blurred layers is kept. (An output layer reads
// only three source layers, so a rebuild could blur each layer right after filling the one above
// it, while they are in L2; measured, that was no faster: 2026-12-02, BM_FullRefillNearestBlurred.
// Nor were strips of 16 or 24 rows.) In storage order a texel's x neighbours are adjacent except
// across column 0 (its left neighbour is column n.x - 1), at the range's two clamped edge columns,
// and for the duplicated column (which copies column 0); those are patched per row
// (blurFinishPatches). The sums are the same integers as blurBox's: the texels are equal bit for
// bit. No texel depends on the source's duplicated column, row or layer.
void Volume::blurWholeRows(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a) {
  if (cell_source_) return blurWholeRowsFromCells(g0, b, a0, a);
  const glm::ivec3 n = period();
  thread_local std::vector<int> sy, sz;
  sy.resize(size_t(a.y)), sz.resize(size_t(a.z));
  for (int y = 0; y < a.y; ++y) sy[size_t(y)] = floorMod(a0.y + y, n.y);
  for (int z = 0; z < a.z; ++z) sz[size_t(z)] = floorMod(a0.z + z, n.z);
  const int oy = g0.y - a0.y, oz = g0.z - a0.z;  // the box inside the apron (in x it is the apron)
  const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
  const int W = 4 * options_.size.x;  // lanes per row: the storage row, duplicated column included
  // The patched columns (lane offsets): storage columns 0 and n.x - 1, the range's first and last
  // (clamped to themselves), and the duplicated column from column 0's taps.
  const int e0 = floorMod(a0.x, n.x), e1 = floorMod(a0.x + a.x - 1, n.x);
  std::array<BlurPatch, 5> patches{};
  int patch_count = 0;
  auto patch = [&](int to, int s) {
    const int left = s == e0 ? s : (s == 0 ? n.x - 1 : s - 1), right = s == e1 ? s : (s + 1 == n.x ? 0 : s + 1);
    patches[size_t(patch_count++)] = {4 * to, 4 * left, 4 * s, 4 * right};
  };
  for (const int s : {0, n.x - 1, e0, e1}) {
    bool seen = false;
    for (int k = 0; k < patch_count; ++k) seen |= patches[size_t(k)].to == 4 * s;
    if (!seen) patch(s, s);
  }
  patch(n.x, 0);
  // Apron rows [i, rowRun(i, end)) are adjacent storage rows (sy counts up by one): at most two runs.
  auto rowRun = [&](int i, int end) {
    int j = i + 1;
    while (j < end && sy[size_t(j)] == sy[size_t(j - 1)] + 1) ++j;
    return j;
  };
  thread_local std::vector<uint16_t> zt, yt;
  zt.resize(size_t(W) * (kBlurStripRows + 2)), yt.resize(size_t(W) * kBlurStripRows);
  for (int z = 0; z < b.z; ++z) {
    const int gz = oz + z, tz = sz[size_t(gz)];
    const size_t lm = size_t(sz[size_t(std::max(gz - 1, 0))]) * layer_stride, l0 = size_t(tz) * layer_stride,
                 lp = size_t(sz[size_t(std::min(gz + 1, a.z - 1))]) * layer_stride;
    for (int c = 0; c < 3; ++c) {
      const auto* in = reinterpret_cast<const uint8_t*>(source_[c].data());
      uint32_t* dst = texels_[c].data();
      for (int y0 = 0; y0 < b.y; y0 += kBlurStripRows) {
        const int y1 = std::min(y0 + kBlurStripRows, b.y);
        const int r0 = std::max(oy + y0 - 1, 0), r1 = std::min(oy + y1 + 1, a.y);  // apron rows the strip reads
        // z: the strip's apron rows, one run of lanes per run of adjacent storage rows.
        for (int r = r0; r < r1;) {
          const int r_end = rowRun(r, r1);
          const size_t row = size_t(sy[size_t(r)]) * row_stride * 4;
          blurRows3Bytes(in + 4 * lm + row, in + 4 * l0 + row, in + 4 * lp + row, &zt[size_t(r - r0) * W], (r_end - r) * W);
          r = r_end;
        }
        // y: box rows [y0, y1); only the apron's first and last rows clamp.
        auto at = [&](int apron_row) { return &zt[size_t(apron_row - r0) * W]; };
        const int first = oy + y0 == 0 ? y0 + 1 : y0, last = oy + y1 == a.y ? y1 - 1 : y1;
        if (first > y0) blurRows3(at(0), at(0), at(std::min(1, a.y - 1)), yt.data(), W);
        if (last > first)
          blurRows3(at(oy + first - 1), at(oy + first), at(oy + first + 1), &yt[size_t(first - y0) * W], (last - first) * W);
        if (last < y1 && last >= first)
          blurRows3(at(std::max(oy + last - 1, 0)), at(oy + last), at(oy + last), &yt[size_t(last - y0) * W], W);
        // x and the rounding, into the texels; then the patched columns.
        for (int y = y0; y < y1;) {
          const int y_end = rowRun(oy + y, oy + y1) - oy;
          const uint16_t* m = &yt[size_t(y - y0) * W];
          auto* out = reinterpret_cast<uint8_t*>(dst + l0 + size_t(sy[size_t(oy + y)]) * row_stride);
          blurTap3Finish(m, out, 4, (y_end - y) * W - 4);
          blurFinishPatches(m, out, y_end - y, W, patches.data(), patch_count);
          y = y_end;
        }
        mirrorWholeRows(dst, n, row_stride, layer_stride, sy.data(), oy, y0, y1, tz);
      }
    }
  }
}

// blurWholeRows with the cell source. Per output layer, channel and strip of rows: the z pass on
// the cells of the strip's apron rows (a quarter of the texels' lanes), the y pass per box row on
// its clamped taps' cells (half), and the x pass with the rounding from that row of cells straight
// into the texels (blurCellsFinish): a texel's x taps are its cell's neighbour and its cell twice.
// The storage row is written in runs of columns whose texels are consecutive and whose cells are
// stored consecutively (ExpandRun, at most three: split at the texel and the cell storage wrap);
// each run's first and last column, whose taps may lie across a seam or be clamped, and the
// duplicated column, are patched (blurFinishPatch on the row of cells, in blurCellRows). The sums are those of the texels'
// passes, since a cell's texels hold its bytes: the texels equal blurWholeRows's bit for bit.
void Volume::blurWholeRowsFromCells(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a) {
  const glm::ivec3 n = period();
  thread_local std::vector<int> sy, sz, ky;  // ky: each apron row's cell row
  sy.resize(size_t(a.y)), sz.resize(size_t(a.z)), ky.resize(size_t(a.y));
  for (int y = 0; y < a.y; ++y) sy[size_t(y)] = floorMod(a0.y + y, n.y), ky[size_t(y)] = floorDiv(a0.y + y, 2);
  for (int z = 0; z < a.z; ++z) sz[size_t(z)] = floorMod(a0.z + z, n.z);
  const int oy = g0.y - a0.y, oz = g0.z - a0.z;  // the box inside the apron (in x it is the apron)
  const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
  const int Wc = 4 * cell_period_.x;  // lanes per row of cells
  auto cellLane = [&](int gx) { return 4 * floorMod(floorDiv(gx, 2), cell_period_.x); };
  auto texelAt = [&](int s) { return a0.x + floorMod(s - a0.x, n.x); };  // the covered texel stored at s (a.x == n.x)
  struct ExpandRun {
    int begin, end;  // storage columns [begin, end): consecutive texels, in cells stored consecutively
  };
  thread_local std::vector<ExpandRun> runs;
  runs.clear();
  for (int s = 0; s < n.x; ++s) {
    const int gx = texelAt(s);
    if (s > 0 && texelAt(s - 1) + 1 == gx && (floorMod(gx, 2) == 1 || cellLane(gx) == cellLane(gx - 1) + 4))
      runs.back().end = s + 1;
    else
      runs.push_back({s, s + 1});
  }
  thread_local std::vector<CellRun> cell_runs;
  cell_runs.clear();
  for (const ExpandRun& run : runs) {
    // From the run's first texel that is its cell's first. An odd count writes one texel past the
    // run: the next run's first (written after it, or patched), or the duplicated column (patched).
    const int first = floorMod(texelAt(run.begin), 2) == 1 ? run.begin + 1 : run.begin;
    if (first < run.end) cell_runs.push_back({first, (run.end - first + 1) / 2, cellLane(texelAt(first))});
  }
  thread_local std::vector<BlurPatch> patches;
  patches.clear();
  auto patch = [&](int to, int s) {
    const int gx = texelAt(s);
    patches.push_back({4 * to, cellLane(std::max(gx - 1, a0.x)), cellLane(gx), cellLane(std::min(gx + 1, a0.x + a.x - 1))});
  };
  for (const ExpandRun& run : runs) {
    patch(run.begin, run.begin);
    if (run.end - 1 > run.begin) patch(run.end - 1, run.end - 1);
  }
  patch(n.x, 0);
  // Rows of cells: the z pass's, and one y pass's with a cell of slack before it and two after
  // (blurCellsFinish reads a run's outer neighbours; a patch reads two cells).
  thread_local std::vector<uint16_t> zt, yrows;
  zt.resize(size_t(Wc) * (kCellStripRows / 2 + 2)), yrows.assign(2 * (size_t(Wc) + 12), 0);
  uint16_t* const yc[2] = {yrows.data() + 4, yrows.data() + Wc + 16};
  for (int z = 0; z < b.z; ++z) {
    const int gz = oz + z, tz = sz[size_t(gz)];
    const size_t lm = sourceOffset(2, a0.z + std::max(gz - 1, 0)), l0 = sourceOffset(2, a0.z + gz),
                 lp = sourceOffset(2, a0.z + std::min(gz + 1, a.z - 1));
    for (int c = 0; c < 3; ++c) {
      const auto* in = reinterpret_cast<const uint8_t*>(source_[c].data());
      uint32_t* dst = texels_[c].data();
      for (int y0 = 0; y0 < b.y; y0 += kCellStripRows) {
        const int y1 = std::min(y0 + kCellStripRows, b.y);
        const int r0 = std::max(oy + y0 - 1, 0), r1 = std::min(oy + y1 + 1, a.y);  // apron rows the strip reads
        const int k0 = ky[size_t(r0)], k1 = ky[size_t(r1 - 1)] + 1;  // and their cells
        for (int k = k0; k < k1; ++k) {
          const size_t row = 4 * sourceOffset(1, 2 * k);
          blurRows3Bytes(in + 4 * lm + row, in + 4 * l0 + row, in + 4 * lp + row, &zt[size_t(k - k0) * Wc], Wc);
        }
        auto cellRow = [&](int apron_row) { return &zt[size_t(ky[size_t(apron_row)] - k0) * Wc]; };
        for (int y = y0; y < y1;) {
          const int r = oy + y;
          // A cell's two rows, neither at the apron's edge, in one pass (blurCellsYPair); else one.
          const bool pair = floorMod(a0.y + r, 2) == 0 && r > 0 && y + 1 < y1 && r + 2 < a.y;
          if (pair)
            blurCellsYPair(cellRow(r - 1), cellRow(r), cellRow(r + 2), yc[0], yc[1], Wc);
          else
            blurRows3(cellRow(std::max(r - 1, 0)), cellRow(r), cellRow(std::min(r + 1, a.y - 1)), yc[0], Wc);
          uint8_t* out_rows[2];
          for (int k = 0; k < (pair ? 2 : 1); ++k)
            out_rows[k] = reinterpret_cast<uint8_t*>(dst + size_t(tz) * layer_stride + size_t(sy[size_t(r + k)]) * row_stride);
          blurCellRows(yc[0], int(yc[1] - yc[0]), out_rows, pair ? 2 : 1, cell_runs.data(), int(cell_runs.size()), patches.data(),
                       int(patches.size()));
          y += pair ? 2 : 1;
        }
        mirrorWholeRows(dst, n, row_stride, layer_stride, sy.data(), oy, y0, y1, tz);
      }
    }
  }
}

// blurBox for a box at most kThinBlurX texels wide in x (what a scroll along x re-blurs: the
// entered slab with one texel either side, and the new face). Its rows along x are a few texels
// long, so the row-wise passes of blurBox paid their per-row set-up for every texel (136 us for a
// one-texel x scroll, 30x the cost per texel of a whole-volume blur). Here the apron is gathered
// with y as the fast axis, the three passes run along y, and the result is scattered back. The
// sums are the same integers as blurBox's: the texels are equal bit for bit.
void Volume::blurThinX(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a) {
  const glm::ivec3 n = period();
  thread_local std::vector<int> sx, sy, sz;
  sx.resize(size_t(a.x)), sy.resize(size_t(a.y)), sz.resize(size_t(a.z));
  for (int x = 0; x < a.x; ++x) sx[size_t(x)] = floorMod(a0.x + x, n.x);
  for (int y = 0; y < a.y; ++y) sy[size_t(y)] = floorMod(a0.y + y, n.y);
  for (int z = 0; z < a.z; ++z) sz[size_t(z)] = floorMod(a0.z + z, n.z);
  const int ox = g0.x - a0.x, oy = g0.y - a0.y, oz = g0.z - a0.z;  // the box inside the apron
  const size_t row_stride = size_t(options_.size.x), layer_stride = row_stride * size_t(options_.size.y);
  const size_t ay4 = size_t(a.y) * 4, by4 = size_t(b.y) * 4;
  // Lanes: [x][z][y][byte]; `src` over the apron, `px` after the x pass (box columns, apron
  // rows and layers), `py` after the y pass (box rows), `out` the finished bytes of one column.
  thread_local std::vector<uint8_t> src, out;
  thread_local std::vector<uint16_t> px, py;
  src.resize(size_t(a.x) * a.z * ay4);
  px.resize(size_t(b.x) * a.z * ay4);
  py.resize(size_t(b.x) * a.z * by4);
  out.resize(by4);
  thread_local std::vector<size_t> src_x, src_y, src_z;
  sourceOffsets(a0, a, src_x, src_y, src_z);
  for (int c = 0; c < 3; ++c) {
    const uint32_t* in = source_[c].data();
    for (int z = 0; z < a.z; ++z)
      for (int y = 0; y < a.y; ++y) {
        const uint32_t* row = in + src_z[size_t(z)] + src_y[size_t(y)];
        for (int x = 0; x < a.x; ++x) std::memcpy(&src[(size_t(x) * a.z + z) * ay4 + size_t(y) * 4], row + src_x[size_t(x)], 4);
      }
    // x: neighbours clamped into the apron (the same as into the covered range, see blurBox).
    for (int x = 0; x < b.x; ++x) {
      const int gx = ox + x, xm = std::max(gx - 1, 0), xp = std::min(gx + 1, a.x - 1);
      for (int z = 0; z < a.z; ++z)
        blurRows3Bytes(&src[(size_t(xm) * a.z + z) * ay4], &src[(size_t(gx) * a.z + z) * ay4], &src[(size_t(xp) * a.z + z) * ay4],
                       &px[(size_t(x) * a.z + z) * ay4], int(ay4));
    }
    // y: only the apron's first and last rows clamp.
    const int rb = int(by4), lo = oy == 0 ? 4 : 0, hi = oy + b.y == a.y ? rb - 4 : rb;
    for (int x = 0; x < b.x; ++x)
      for (int z = 0; z < a.z; ++z) {
        const uint16_t* r = &px[(size_t(x) * a.z + z) * ay4];
        uint16_t* o = &py[(size_t(x) * a.z + z) * by4];
        auto tap = [&](int i) {
          const int gy = oy + i / 4, l = i % 4;
          return uint16_t(r[4 * std::max(gy - 1, 0) + l] + 2 * r[4 * gy + l] + r[4 * std::min(gy + 1, a.y - 1) + l]);
        };
        for (int i = 0; i < lo && i < rb; ++i) o[i] = tap(i);
        blurTap3Wide(r + 4 * oy, o, lo, hi);
        for (int i = std::max(hi, lo); i < rb; ++i) o[i] = tap(i);
      }
    // z, rounding, and back into the texels.
    uint32_t* dst = texels_[c].data();
    for (int x = 0; x < b.x; ++x) {
      const size_t tx = size_t(sx[size_t(ox + x)]);
      for (int z = 0; z < b.z; ++z) {
        const int gz = oz + z, zm = std::max(gz - 1, 0), zp = std::min(gz + 1, a.z - 1);
        blurFinish(&py[(size_t(x) * a.z + zm) * by4], &py[(size_t(x) * a.z + gz) * by4], &py[(size_t(x) * a.z + zp) * by4], out.data(), rb);
        uint32_t* layer = dst + size_t(sz[size_t(gz)]) * layer_stride + tx;
        for (int y = 0; y < b.y; ++y) std::memcpy(layer + size_t(sy[size_t(oy + y)]) * row_stride, &out[size_t(y) * 4], 4);
      }
    }
    mirrorBoundary(dst, std::span(sx).subspan(size_t(ox), size_t(b.x)), std::span(sy).subspan(size_t(oy), size_t(b.y)),
                   std::span(sz).subspan(size_t(oz), size_t(b.z)));
  }
}

}  // namespace drtv::runtime
