// The probe cache's relight kernels (relight_kernels.h).
#include "relight_kernels.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "pack.h"
#include "simd_clones.h"

namespace drtv::runtime::detail {
namespace {

// The bit pattern of the largest |value| over the 12 colour planes (n values each) once clamped:
// with the sign bit cleared, floats order as their bit patterns. A reduction after the planes are
// written, not a running maximum inside their loops: GCC kept that one in memory, and each loop
// then waited on its own store (fc3's relight took 1.18x as long).
[[gnu::always_inline]] inline int32_t maxMagnitudeBits(const float* out, int n, int stride) {
  int32_t m = 0;
  for (int p = 0; p < kColourPlanes; ++p) {
    const float* __restrict o = out + p * stride;
    for (int k = 0; k < n; ++k) m = std::max(m, std::bit_cast<int32_t>(o[k]) & 0x7fffffff);
  }
  return m;
}

}  // namespace

DRTV_SIMD_CLONES int32_t relightPlanes(const float* in, float* out, int n, int stride, const float (&lc)[3][4],
                                      const float (&direct)[3][4], const float* local) {
  for (int c = 0; c < 3; ++c)
    for (int b = 0; b < 4; ++b) {
      const float* __restrict t0 = in + ((c * 4 + b) * 4 + 0) * stride;
      const float* __restrict t1 = t0 + stride;
      const float* __restrict t2 = t1 + stride;
      const float* __restrict t3 = t2 + stride;
      const float* __restrict v = in + (kTransferPlanes + b) * stride;
      float* __restrict o = out + (c * 4 + b) * stride;
      const float l0 = lc[c][0], l1 = lc[c][1], l2 = lc[c][2], l3 = lc[c][3], d = direct[c][b];
      // n is a multiple of 16 (the padding lanes hold zero inputs): no scalar epilogue.
      if (local) {
        const float* __restrict x = local + (c * 4 + b) * stride;
        for (int i = 0; i < n; ++i) o[i] = clampColour(l0 * t0[i] + l1 * t1[i] + l2 * t2[i] + l3 * t3[i] + d * v[i] + x[i]);
      } else {
        for (int i = 0; i < n; ++i) o[i] = clampColour(l0 * t0[i] + l1 * t1[i] + l2 * t2[i] + l3 * t3[i] + d * v[i]);
      }
    }
  return maxMagnitudeBits(out, n, stride);
}

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
template <int L, bool kSun, bool kLocal>
[[gnu::always_inline]] inline int32_t shL1Blocks(const float* __restrict in, float* __restrict out, int n, int stride,
                                                 const ShL1Weights& w_, const float* __restrict sx, const float* __restrict sy,
                                                 const float* __restrict local) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  const ShL1Weights w = w_;
  I mx{};
  for (int k = 0; k < n; k += 16, in += kShL1Block, sx += kSunBlock, sy += kSunBlock)
    for (int h = 0; h < 16; h += L) {
      float* o = out + k + h;
      const float* x = local + k + h;  // plane-major, as `out`
#pragma GCC unroll 12
      for (int q = 0; q < 12; ++q) {
        const int c = q / 4, i = q % 4;
        const float* t = in + q * 64 + h;
        // The terms in the order of one chain (fused by GCC where the target has FMA): the 12
        // outputs of a block are independent, so that their chains overlap.
        const F p0 = loadLanes<F>(in + (kTransferPlanes + i) * 16 + h), p2 = loadLanes<F>(in + (kTransferPlanes + 4 + i) * 16 + h);
        F v = w.lc[c][0] * loadLanes<F>(t) + w.lc[c][1] * loadLanes<F>(t + 16) + w.lc[c][2] * loadLanes<F>(t + 32) +
              w.lc[c][3] * loadLanes<F>(t + 48) + w.d0[c] * p0 + w.d2[c] * p2;
        if constexpr (kSun) v = v + w.a[q] * loadLanes<F>(sx + q * 16 + h) + w.b[q] * loadLanes<F>(sy + q * 16 + h);
        if constexpr (kLocal) v = v + loadLanes<F>(x);
        v = i == 0 ? clampColourLanes(v) : clampSignedLanes(v);
        // Clamped values order like their bit patterns once the sign bit is cleared.
        I bits;
        std::memcpy(&bits, &v, sizeof bits);
        bits &= 0x7fffffff;
        mx = bits > mx ? bits : mx;
        storeLanes(o, v);
        o += stride;
        x += stride;
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
