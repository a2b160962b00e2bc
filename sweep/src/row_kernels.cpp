// The sweep's row kernels (row_kernels.h).
#include "row_kernels.h"

#include <algorithm>
#include <bit>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "drtv/formats/sh.h"
#include "simd_clones.h"
#include "small_float.h"

// The 8-lane helpers below are inlined into the row loops (always_inline), so how a 32-byte vector
// is passed to a function without AVX, which GCC warns about here, never arises.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace drtv::sweep::detail {
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

constexpr float kFourPi = 4.f * sh::kPi;  // exact: 4 is a power of two

}  // namespace

namespace {

// transposeCodes: word by word, each store was a lane extracted from a vector: the packing's
// strided stores and the copy of the row into the grid took 15 % of the sweep. With AVX2, 8 x 8
// blocks are transposed in registers and stored 8 words at a time. Data movement only: both
// versions write the same words.
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

}  // namespace

void transposeCodes(const uint32_t* codes, size_t stride, int n, uint32_t* grid) {
#if defined(__GNUC__) && defined(__x86_64__)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2) return transposeCodesAvx2(codes, stride, n, grid);
#endif
  transposeCodesScalar(codes, stride, n, grid, 0);
}

namespace {

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

}  // namespace

template <bool kSubtract, bool kFinish, bool kResume>
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
// What Sweeper calls (storeRow, bottomUp).
template void storeCells<false, false>(int, const StoreRows&, uint32_t*, size_t, float*, size_t, uint32_t*, uint32_t*);
template void storeCells<true, false>(int, const StoreRows&, uint32_t*, size_t, float*, size_t, uint32_t*, uint32_t*);
template void storeCells<false, true>(int, const StoreRows&, uint32_t*, size_t, float*, size_t, uint32_t*, uint32_t*);
template void storeCells<true, true>(int, const StoreRows&, uint32_t*, size_t, float*, size_t, uint32_t*, uint32_t*);
template void storeCells<false, true, true>(int, const StoreRows&, uint32_t*, size_t, float*, size_t, uint32_t*, uint32_t*);

// Sweeper's own code is the baseline's (SSE): its row loops are clones like these so that the v4
// code runs them 16 floats at a time.
DRTV_SIMD_CLONES void clearOrFull(int n, const float* __restrict sigma, float* __restrict out) {
  for (int x = 0; x < n; ++x) out[x] = sigma[x] == 0.f ? 1.f : 0.f;
}

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

// A row's span is short (tens of floats) and copied into 6-57 rows: one memcpy call per row, with
// its set-up, was 3 % of a re-sweep; GCC would turn this loop back into those calls
// (-ftree-loop-distribute-patterns), hence the attribute.
DRTV_SIMD_CLONES DRTV_SWEEP_NO_MEMCPY_IDIOM void copyRows(int rows, int n, const float* __restrict src, size_t src_stride,
                                                         float* __restrict dst, size_t dst_stride) {
  for (int r = 0; r < rows; ++r, src += src_stride, dst += dst_stride)
    for (int x = 0; x < n; ++x) dst[x] = src[x];
}

DRTV_SIMD_CLONES void halfSums(int n, const float* __restrict tau, float* __restrict fa, float* __restrict fb) {
  for (int m = 0; m < n; ++m) {
    fa[m] = 0.5f * (1.f + tau[m]);
    fb[m] = 0.5f * (1.f - tau[m]);
  }
}

// Through glm's operator[] GCC switched on the channel per element.
DRTV_SIMD_CLONES void splitRgb(int n, const float* __restrict rgb, float* __restrict r, float* __restrict g, float* __restrict b) {
  for (int m = 0; m < n; ++m) {
    r[m] = rgb[3 * m];
    g[m] = rgb[3 * m + 1];
    b[m] = rgb[3 * m + 2];
  }
}

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

namespace {

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

}  // namespace

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
template void gatherRow<true>(int, const TapRows&);
template void gatherRow<false>(int, const TapRows&);

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

}  // namespace drtv::sweep::detail
