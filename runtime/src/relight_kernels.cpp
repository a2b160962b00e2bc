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

// fc3's relight (relightPlanes) L probes at a time through all 12 (channel, basis) outputs, each
// input at a fixed offset from one pointer: one loop per slot instead of twelve, whose 5 to 10
// iterations (70 probes) paid the loop's set-up twelve times (issue 38: 2.65x the limit kernel of
// drtv_limit_bench, planes one after another). The same terms in the same order as before, so
// the same results, bit for bit, on every target.
template <int L, bool kLocal>
[[gnu::always_inline]] inline int32_t fc3Blocks(const float* __restrict in, float* __restrict out, int n, int stride,
                                                const float (&lc_)[3][4], const float (&direct_)[3][4],
                                                const float* __restrict local) {
  using F = typename Lanes<L>::F;
  using I = typename Lanes<L>::I;
  float lc[3][4], direct[3][4];
  std::memcpy(lc, lc_, sizeof lc);
  std::memcpy(direct, direct_, sizeof direct);
  I mx{};
  for (int k = 0; k < n; k += L) {
#pragma GCC unroll 12
    for (int q = 0; q < 12; ++q) {
      const int c = q / 4, b = q % 4;
      const float* t = in + size_t(q * 4) * stride + k;
      F v = lc[c][0] * loadLanes<F>(t) + lc[c][1] * loadLanes<F>(t + stride) + lc[c][2] * loadLanes<F>(t + 2 * stride) +
            lc[c][3] * loadLanes<F>(t + 3 * stride) + direct[c][b] * loadLanes<F>(in + size_t(kTransferPlanes + b) * stride + k);
      if constexpr (kLocal) v = v + loadLanes<F>(local + size_t(q) * stride + k);
      v = clampColourLanes(v);
      I bits;
      std::memcpy(&bits, &v, sizeof bits);  // >= 0 once clamped: ordered like the floats
      mx = bits > mx ? bits : mx;
      storeLanes(out + size_t(q) * stride + k, v);
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
__attribute__((target("arch=x86-64-v4"))) int32_t relightPlanesTarget(const float* in, float* out, int n, int stride,
                                                                const float (&lc)[3][4], const float (&direct)[3][4],
                                                                const float* local) {
  return fc3Relight<16>(in, out, n, stride, lc, direct, local);
}
__attribute__((target("arch=x86-64-v3"))) int32_t relightPlanesTarget(const float* in, float* out, int n, int stride,
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
