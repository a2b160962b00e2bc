// The sweep's row kernels (sweep.cpp's Sweeper calls them a row, or a span of a row, at a time):
// the gather along a row, the reflection in the cells with material, the pass-through rows, and
// the packing of a row's light into the light grid's words. Private to drtv::sweep.
//
// Each is compiled for the baseline, AVX2 and x86-64-v4 (AVX-512), chosen at run time by what
// the CPU supports, and does the same IEEE operations in the same order in each: the same bits on
// every CPU (row_kernels.cpp; -ffp-contract=off, sweep/CMakeLists.txt). Rows passed as `float*`
// are rows of n floats unless said otherwise; the kernels are pure functions of their arguments
// and thread-safe.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "drtv/sweep/directions.h"
#include "paths.h"

namespace drtv::sweep::detail {

// The level buffers' rows are padded to a multiple of this many floats (64 bytes, 16 lanes).
inline constexpr int kRowFloats = 16;
// The most lanes of any code: the rows the vector loops read are padded for it.
inline constexpr int kLanes = 16;
static_assert(kLanes <= kRowFloats, "the level buffers' rows hold whole groups of lanes");
// A full cell's optical depth per cell length.
inline constexpr float kInf = std::numeric_limits<float>::infinity();

// A row's words from direction-major (codes[d * stride + x]) to the light grid's cell-major layout
// (grid[x * kDirections + d]), for cells x < n.
void transposeCodes(const uint32_t* codes, size_t stride, int n, uint32_t* grid);

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
// Instantiated for the combinations the sweeper uses (row_kernels.cpp).
template <bool kSubtract, bool kFinish, bool kResume = false>
void storeCells(int n, const StoreRows& s, uint32_t* __restrict codes, size_t code_stride, float* __restrict sums,
                size_t sum_stride, uint32_t* __restrict average, uint32_t* __restrict dominant);

// A row's pass-through where it is 0 or 1: 1 in a clear cell (sigma 0), 0 in a full one (sigma inf);
// the cells of fractional density are patched in after.
void clearOrFull(int n, const float* __restrict sigma, float* __restrict out);

// A row of n densities: their optical depths per cell length where no log is needed (0 for clear
// cells, inf for full ones; 0 for now in the cells of fractional density), and how many cells
// have material, fractional density, or a density outside [0, 1] (NaN too).
struct DensityRow {
  int material = 0, fractional = 0, outside = 0;
};
DensityRow opticalDepthRow(int n, const float* __restrict d, float* __restrict s);

// `rows` rows of n floats from src (rows src_stride apart; 0: the same row each time) to dst (rows
// dst_stride apart).
void copyRows(int rows, int n, const float* __restrict src, size_t src_stride, float* __restrict dst, size_t dst_stride);

// (1 + tau) / 2 and (1 - tau) / 2 of a row's cells (Sweeper::interactRow).
void halfSums(int n, const float* __restrict tau, float* __restrict fa, float* __restrict fb);

// n RGB triples (glm::vec3, 3 floats each) into 3 rows.
void splitRgb(int n, const float* __restrict rgb, float* __restrict r, float* __restrict g, float* __restrict b);

// The bottom-up pass in a row of n cells, for one up-going direction: its gathered light v (3 rows,
// channels `stride` apart) passes the cell as T (row t) plus what the cell reflects up (e, 3 rows
// of `e_stride`), and leaves as v T + e (into v); what is stored is v sqrt(T) + e / 2 (rows
// `stored`, channels `stride` apart). As Sweeper::bottomUp did it cell by cell.
void upCells(int n, float* __restrict v, size_t stride, const float* __restrict t, const float* __restrict st,
             const float* __restrict e, size_t e_stride, float* __restrict stored);

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
// Instantiated for kVarying true and false (row_kernels.cpp).
template <bool kVarying>
void gatherRow(int n, const TapRows& g);

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
void addStopped(int n, const ReflectionRows& w, const float* __restrict in_r, const float* __restrict in_g,
                const float* __restrict in_b, const float* __restrict t, float cos_sum, float ux, float uy, float uz);

// The light reflected into outgoing direction (ux, uy, uz) of solid angle omega, in channel c of
// cell m, is rho Omega (fa sum - fb q . travel).
//
// A down-going direction's light in each cell of the span: what it stores (I sqrt(T) + reflected
// / 2, replacing its gathered light in rows io_*) and what it sends on (I T + reflected, rows l*).
void reflectDown(int n, const ReflectionRows& w, float ux, float uy, float uz, float omega, const float* __restrict t,
                 const float* __restrict st, float* __restrict io_r, float* __restrict io_g, float* __restrict io_b,
                 float* __restrict lr, float* __restrict lg, float* __restrict lb);

// An up-going direction's reflected light in each cell of the span, into rows e*.
void reflectUp(int n, const ReflectionRows& w, float ux, float uy, float uz, float omega, float* __restrict er,
               float* __restrict eg, float* __restrict eb);

}  // namespace drtv::sweep::detail
