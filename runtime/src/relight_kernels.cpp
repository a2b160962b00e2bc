// The probe cache's relight kernels (relight_kernels.h).
#include "relight_kernels.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "pack.h"
#include "simd_clones.h"

namespace drtv::runtime::detail {
namespace {

// GCC's vector extensions, L lanes: 16 (one register) in the AVX-512 version, 8 in the AVX2 and
// baseline ones (where 16 lanes spilled: a block is then two halves). The helpers are always
// inlined into the kernels below, so no vector crosses a call, and GCC's -Wpsabi note on how one
// would be returned without AVX does not apply (runtime/CMakeLists.txt turns it off here).
template <int L>
struct Lanes;
template <>
struct Lanes<8> {
  using F = float __attribute__((vector_size(32)));
  using I = int32_t __attribute__((vector_size(32)));
};
template <>
struct Lanes<16> {
  using F = float __attribute__((vector_size(64)));
  using I = int32_t __attribute__((vector_size(64)));
};
template <class V>
[[gnu::always_inline]] inline V loadLanes(const float* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <class V>
[[gnu::always_inline]] inline void storeLanes(float* p, V v) {
  std::memcpy(p, &v, sizeof v);
}
// clampColour and clampSigned on a vector (NaN to 0 in both).
template <class V>
[[gnu::always_inline]] inline V clampColourLanes(V x) {
  const V zero{}, hi = zero + kMaxColour;
  const V y = x > zero ? x : zero;
  return y < hi ? y : hi;
}
template <class V>
[[gnu::always_inline]] inline V clampSignedLanes(V x) {
  const V zero{}, lo = zero - kMaxColour, hi = zero + kMaxColour;
  const V y = x > lo ? x : lo;
  const V z = y < hi ? y : hi;
  return x == x ? z : zero;
}
// One output plane q (= channel x 4 + coefficient) of shL1Blocks, with e0's clamp or e1..3's.
template <int L, bool kSun, bool kLocal, bool kSigned>
[[gnu::always_inline]] inline void shL1Plane(const float* __restrict in, float* __restrict out, int n, int stride,
                                             const ShL1Weights& w, int q, const float* __restrict sx, const float* __restrict sy,
                                             const float* __restrict local, typename Lanes<L>::I& mx) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  const int c = q / 4, i = q % 4;
  const float l0 = w.lc[c][0], l1 = w.lc[c][1], l2 = w.lc[c][2], l3 = w.lc[c][3], e0 = w.d0[c], e2 = w.d2[c];
  const float a = w.a[q], b = w.b[q];
  const float* __restrict t = in + q * 64;
  const float* __restrict p0 = in + (kTransferPlanes + i) * 16;
  const float* __restrict p2 = in + (kTransferPlanes + 4 + i) * 16;
  const float* __restrict x = sx + q * 16;
  const float* __restrict y = sy + q * 16;
  float* __restrict o = out + size_t(q) * stride;
  const float* __restrict z = local + size_t(q) * stride;  // plane-major, as `out`
  for (int k = 0; k < n; k += 16, t += kShL1Block, p0 += kShL1Block, p2 += kShL1Block, x += kSunBlock, y += kSunBlock)
    for (int h = 0; h < 16; h += L) {
      // The terms in the order of one chain (fused by GCC where the target has FMA).
      F v = l0 * loadLanes<F>(t + h) + l1 * loadLanes<F>(t + 16 + h) + l2 * loadLanes<F>(t + 32 + h) +
            l3 * loadLanes<F>(t + 48 + h) + e0 * loadLanes<F>(p0 + h) + e2 * loadLanes<F>(p2 + h);
      if constexpr (kSun) v = v + a * loadLanes<F>(x + h) + b * loadLanes<F>(y + h);
      if constexpr (kLocal) v = v + loadLanes<F>(z + k + h);
      if constexpr (kSigned)
        v = clampSignedLanes(v);
      else
        v = clampColourLanes(v);
      // Clamped values order like their bit patterns once the sign bit is cleared.
      I bits;
      std::memcpy(&bits, &v, sizeof bits);
      if constexpr (kSigned) bits &= 0x7fffffff;
      mx = bits > mx ? bits : mx;
      storeLanes(o + k + h, v);
    }
}

// sh-l1 output plane by output plane (q = channel x 4 + coefficient), each a loop over the slot's
// blocks: the inputs at fixed offsets from the block, the 8 weights in registers, the clamp of
// e0 or of e1..3 chosen outside the loop. Blocks-outer with all 12 outputs in one step held 42
// weights, which GCC spilled and reloaded before its multiply-adds (1.45-1.6x the limit kernel).
// The iterations of one plane are independent, so that their chains of 8 multiply-adds overlap.
// The same terms in the same order as before, so the same results. Blocks outer, the 12 planes of
// a block inner and not unrolled (each plane's 8 weights loaded from the cache, not held across
// planes): a block's 3.5 KB are read while in L1, where planes outer read each plane's rows
// from every block 3.5 KB apart, past the reach of Intel's L1 stride prefetcher (Intel Xeon
// 2026-12-08: 22-24 against 26-29 us for 3,570 probes; not measured on AMD).
// Two planes' chains in one loop, planes outer, were no faster there (not latency).
template <int L, bool kSun, bool kLocal>
[[gnu::always_inline]] inline int32_t shL1Blocks(const float* in, float* out, int n, int stride, const ShL1Weights& w,
                                                 const float* sx, const float* sy, const float* local) {
  typename Lanes<L>::I mx{};
  for (int blk = 0; 16 * blk < n; ++blk) {
    const float* ib = in + size_t(blk) * kShL1Block;
    const float* xb = sx + size_t(blk) * kSunBlock;
    const float* yb = sy + size_t(blk) * kSunBlock;
    float* ob = out + 16 * blk;
    const float* lb = local + 16 * blk;
#pragma GCC unroll 1
    for (int c = 0; c < 3; ++c) {
      shL1Plane<L, kSun, kLocal, false>(ib, ob, 16, stride, w, c * 4, xb, yb, lb, mx);
#pragma GCC unroll 1
      for (int i = 1; i < 4; ++i) shL1Plane<L, kSun, kLocal, true>(ib, ob, 16, stride, w, c * 4 + i, xb, yb, lb, mx);
    }
  }
  int32_t m = 0;
  for (int l = 0; l < L; ++l) m = std::max(m, mx[l]);
  return m;
}

template <int L>
[[gnu::always_inline]] inline int32_t shL1Relight(const float* in, float* out, int n, int stride, const ShL1Weights& w,
                                                  const float* sx, const float* sy, const float* local) {
  if (sx)
    return local ? shL1Blocks<L, true, true>(in, out, n, stride, w, sx, sy, local) : shL1Blocks<L, true, false>(in, out, n, stride, w, sx, sy, in);
  return local ? shL1Blocks<L, false, true>(in, out, n, stride, w, in, in, local) : shL1Blocks<L, false, false>(in, out, n, stride, w, in, in, in);
}

// fc3's relight (relightPlanes): output plane by output plane, each a loop over the slot's probes,
// L at a time, on six pointers (four transfer planes, the visibility plane, the output) whose
// weights stay in registers. Probes-outer with all 12 outputs in one step held 52
// input pointers and 24 weights, which GCC spilled: a reload from the stack before most loads
// (1.45-1.6x the limit kernel of drtv_limit_bench); an earlier form, one auto-vectorised loop per
// plane with its own set-up and remainder, was 2.65x.
// The same terms in the same order, so the same results, bit for bit, on every target.
template <int L, bool kLocal>
[[gnu::always_inline]] inline int32_t fc3Blocks(const float* __restrict in, float* __restrict out, int n, int stride,
                                                const float (&lc)[3][4], const float (&direct)[3][4],
                                                const float* __restrict local) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  I mx{};
  for (int q = 0; q < 12; ++q) {
    const int c = q / 4, b = q % 4;
    const float* __restrict t0 = in + size_t(q * 4) * stride;
    const float* __restrict t1 = t0 + stride;
    const float* __restrict t2 = t1 + stride;
    const float* __restrict t3 = t2 + stride;
    const float* __restrict vis = in + size_t(kTransferPlanes + b) * stride;
    const float* __restrict x = local + size_t(q) * stride;
    float* __restrict o = out + size_t(q) * stride;
    const float l0 = lc[c][0], l1 = lc[c][1], l2 = lc[c][2], l3 = lc[c][3], d = direct[c][b];
    for (int k = 0; k < n; k += L) {
      F v = l0 * loadLanes<F>(t0 + k) + l1 * loadLanes<F>(t1 + k) + l2 * loadLanes<F>(t2 + k) + l3 * loadLanes<F>(t3 + k) +
            d * loadLanes<F>(vis + k);
      if constexpr (kLocal) v = v + loadLanes<F>(x + k);
      v = clampColourLanes(v);
      I bits;
      std::memcpy(&bits, &v, sizeof bits);  // >= 0 once clamped: ordered like the floats
      mx = bits > mx ? bits : mx;
      storeLanes(o + k, v);
    }
  }
  int32_t m = 0;
  for (int l = 0; l < L; ++l) m = std::max(m, mx[l]);
  return m;
}

template <int L>
[[gnu::always_inline]] inline int32_t fc3Relight(const float* in, float* out, int n, int stride, const float (&lc)[3][4],
                                                 const float (&direct)[3][4], const float* local) {
  return local ? fc3Blocks<L, true>(in, out, n, stride, lc, direct, local) : fc3Blocks<L, false>(in, out, n, stride, lc, direct, in);
}

#if DRTV_SIMD_MULTIVERSION
// On 64-byte boundaries: when the sh-l1 kernels above changed shape, fc3's moved and its worst
// LPRT case (BM_RelightWithLprtAllSourcesLit) took 10 % longer with the same code.
__attribute__((target("arch=x86-64-v4"), aligned(64))) int32_t relightPlanesTarget(const float* in, float* out, int n, int stride,
                                                                const float (&lc)[3][4], const float (&direct)[3][4],
                                                                const float* local) {
  return fc3Relight<16>(in, out, n, stride, lc, direct, local);
}
__attribute__((target("arch=x86-64-v3"), aligned(64))) int32_t relightPlanesTarget(const float* in, float* out, int n, int stride,
                                                                const float (&lc)[3][4], const float (&direct)[3][4],
                                                                const float* local) {
  return fc3Relight<8>(in, out, n, stride, lc, direct, local);
}
__attribute__((target("default")))
#endif
int32_t relightPlanesTarget(const float* in, float* out, int n, int stride, const float (&lc)[3][4], const float (&direct)[3][4],
                            const float* local) {
  return fc3Relight<8>(in, out, n, stride, lc, direct, local);
}

// One version per target (GCC's function multiversioning, as DRTV_SIMD_CLONES but with the lanes
// each target wants), dispatched here: a caller in another file that saw only one declaration
// would call the default version.
#if DRTV_SIMD_MULTIVERSION
__attribute__((target("arch=x86-64-v4"))) int32_t relightBlocksShL1Target(const float* in, float* out, int n, int stride,
                                                                    const ShL1Weights& w, const float* sx, const float* sy,
                                                                    const float* local) {
  return shL1Relight<16>(in, out, n, stride, w, sx, sy, local);
}
__attribute__((target("arch=x86-64-v3"))) int32_t relightBlocksShL1Target(const float* in, float* out, int n, int stride,
                                                                    const ShL1Weights& w, const float* sx, const float* sy,
                                                                    const float* local) {
  return shL1Relight<8>(in, out, n, stride, w, sx, sy, local);
}
__attribute__((target("default")))
#endif
int32_t relightBlocksShL1Target(const float* in, float* out, int n, int stride, const ShL1Weights& w, const float* sx,
                                const float* sy, const float* local) {
  return shL1Relight<8>(in, out, n, stride, w, sx, sy, local);
}

}  // namespace

int32_t relightBlocksShL1(const float* in, float* out, int n, int stride, const ShL1Weights& w, const float* sx, const float* sy,
                          const float* local) {
  return relightBlocksShL1Target(in, out, n, stride, w, sx, sy, local);
}

int32_t relightPlanes(const float* in, float* out, int n, int stride, const float (&lc)[3][4], const float (&direct)[3][4],
                      const float* local) {
  return relightPlanesTarget(in, out, n, stride, lc, direct, local);
}

DRTV_SIMD_CLONES void accumulateSource(float* acc, const int16_t* q, const float* scale, int n, int stride,
                                      const float (&colour)[12]) {
  for (int k = 0; k < 12; ++k) {
    float* __restrict a = acc + k * stride;
    const int16_t* __restrict qk = q + k * stride;
    const float* __restrict sc = scale;
    const float w = colour[k];
    for (int i0 = 0; i0 < n; i0 += 16)
      for (int i = i0; i < i0 + 16; ++i) a[i] += w * (sc[i] * float(qk[i]));
  }
}

// Per probe and channel the scalar form, with the representation tested per texel, made the pack
// after each relight as costly as half a volume refill (perf of a fly at 0.2 h/s).
DRTV_SIMD_CLONES void packPlanes(const float* __restrict p0, const float* __restrict p1, const float* __restrict p2,
                                const float* __restrict p3, int n, float inv, bool sh_l1, uint32_t* __restrict out) {
  if (sh_l1)
    for (int i = 0; i < n; ++i) out[i] = detail::packTexelShL1(p0[i], p1[i], p2[i], p3[i], inv);
  else
    for (int i = 0; i < n; ++i) out[i] = detail::packTexel(p0[i], p1[i], p2[i], p3[i], inv);
}

}  // namespace drtv::runtime::detail
