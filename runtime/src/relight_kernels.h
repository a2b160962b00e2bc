// The probe cache's relight kernels (probe_cache.h, "Relighting"): the loops over a slot's
// coefficient planes that ProbeCache's relight and pack run, and the clamp of their results.
// Private to drtv::runtime. Pure functions of their arguments, thread-safe.
//
// The hot loops are compiled for AVX-512 and AVX2 as well as the baseline, and picked at load
// time (DRTV_SIMD_CLONES, simd_clones.h): the relight streams 52 planes and is SIMD-bound.
// The v3 and v4 code fuses multiply-adds (GCC's default -ffp-contract=fast here, unlike the
// sweep and the LPV), so a relight's last bits may differ from one CPU to another.
#pragma once

#include <cstddef>
#include <cstdint>

#include "drtv/formats/sh.h"
#include "drtv/runtime/probe_cache.h"

namespace drtv::runtime::detail {

// Ringing is clamped at the end of a probe's sum, and only there (DESIGN.md): negative and NaN
// (inf - inf) become 0, and colours stop at kMaxColour. Clamped colours are >= 0, so their bit
// patterns order like the floats: the running maximum is an integer max, which vectorises.
// (Written as two selects so that GCC turns them into vector max/min: see relightPlanes.)
inline float clampColour(float x) {
  const float y = x > 0.f ? x : 0.f;
  return y < kMaxColour ? y : kMaxColour;
}
// sh-l1's clamp of e1..3 (probe_cache.h): to +-kMaxColour, NaN to 0.
inline float clampSigned(float x) {
  const float y = x > -kMaxColour ? x : -kMaxColour;  // NaN -> -kMaxColour here, fixed below
  const float z = y < kMaxColour ? y : kMaxColour;
  return x == x ? z : 0.f;
}
// sh-l1 keeps its inputs in blocks of 16 probes: block b holds the kInputPlanes planes' 16 values
// of probes 16b..16b+15 side by side (kShL1Block floats), and the sun transfer likewise, 12 planes
// per sample and block. The relight runs output plane by output plane over the blocks, every
// input at a fixed offset from the block. (Over plane-major inputs, each 16-probe step was one
// chain of 8 dependent multiply-adds on 10 pointers, and the relight waited on their latency; all
// 12 outputs in one step per block spilled their 42 weights.)
inline constexpr int kShL1Block = kInputPlanes * 16;
inline constexpr int kSunBlock = 12 * 16;
// Where plane p of probe i sits in a run of blocks of `planes` planes x 16 probes.
constexpr size_t blockOffset(int i, int p, int planes) {
  return size_t(i / 16) * size_t(planes) * 16 + size_t(p) * 16 + size_t(i % 16);
}

// colour[c][b][i] = dot(L[c], T[c][b][i]) + direct[c][b] v[b][i] (+ local[c][b][i], the local
// lights' term, unless `local` is null) for i < n, clamped. Returns the bit pattern of the largest
// clamped value. `n` a multiple of 16 (the padding lanes hold zero inputs).
int32_t relightPlanes(const float* in, float* out, int n, int stride, const float (&lc)[3][4], const float (&direct)[3][4],
                      const float* local);

// The weights of one relight: per channel the bounce light and the direct sky's d0, d2, and per
// (channel, coefficient) plane the sun samples' a, b.
struct ShL1Weights {
  float lc[3][4];
  float d0[3], d2[3];
  float a[12], b[12];
};

// sh-l1's relight of one slot's blocks, with its sun transfer's two samples sx, sy (or without,
// sx = nullptr): e[c][i][k] = sum_j lc[c][j] M'[c][i][j][k] + d0[c] P0_i[k] + d2[c] P2_i[k]
// (+ the sun's a x + b y) (+ local[c][i][k], the local lights' term, plane-major at `stride`,
// unless null), then clamped (e0 to [0, kMaxColour], e1..3 to +-kMaxColour, NaN to 0). Returns the
// bit pattern of the largest |clamped value|. `n` a multiple of 16.
int32_t relightBlocksShL1(const float* in, float* out, int n, int stride, const ShL1Weights& w, const float* sx, const float* sy,
                          const float* local);

// The band factors of the clamped cosine (sh.h): irradiance SH e_i = kLobe[i] R_i.
inline constexpr float kLobe[4] = {sh::kCosineLobe0, sh::kCosineLobe1, sh::kCosineLobe1, sh::kCosineLobe1};

// acc[k][i] += colour_k * scale[i] * q[k][i] for the 12 (channel, k) planes of one source.
void accumulateSource(float* acc, const int16_t* q, const float* scale, int n, int stride, const float (&colour)[12]);

// One channel's texels of a slot, plane by plane, in pack.h's encodings (branch-free there, so
// that these loops vectorise), into out[i] for probes i < n.
void packPlanes(const float* __restrict p0, const float* __restrict p1, const float* __restrict p2, const float* __restrict p3,
                int n, float inv, bool sh_l1, uint32_t* __restrict out);

}  // namespace drtv::runtime::detail
