// Cascaded light propagation volumes (lpv.h; references there): propagation, step by step in
// waves over slabs of the grid, its row loops DRTV_SIMD_CLONES (simd_clones.h): compiled for the
// baseline, AVX2 and AVX-512, chosen at load time; no FMA (-ffp-contract=off, lpv/CMakeLists.txt):
// the same operations in the same order, so the same bits.
#include "drtv/lpv/lpv.h"

#include <algorithm>
#include <cmath>

#include "cascade.h"
#include "propagation_matrices.h"
#include "simd_clones.h"
#include "workers.h"

namespace drtv::lpv {

using namespace detail;

namespace {

// One padded slab ((n+2)^2 cells, a zero cell around it) of a channel's 4 coefficient planes, and
// its (n+2) row flags: a row whose flag is 0 holds only zeros.
struct Slab {
  std::array<float*, 4> q{};
  uint8_t* lit = nullptr;
};

// Zeros the rows of `s` that may hold light (the slabs beyond the grid: nothing enters from there).
void clearSlab(int n, const Slab& s) {
  const size_t np = size_t(n) + 2;
  for (int j = 1; j <= n; ++j) {
    if (!s.lit[j]) continue;
    for (int q = 0; q < 4; ++q) std::fill_n(s.q[size_t(q)] + 1 + np * size_t(j), n, 0.f);
    s.lit[j] = 0;
  }
}

// The propagation's 5 constants (lpv.h, "Propagation"): every direction's matrix is the +x one's
// with the axis relabelled and, for the - directions, m0a and ma0 negated (checked when built).
struct StepConstants {
  float m00, m0a, ma0, maa, moo;
};
StepConstants stepConstants() {
  const auto& mats = matrices();
  const DirMatrix& x = mats[0];
  for (int d = 0; d < kDirs; ++d) {
    const DirMatrix& m = mats[size_t(d)];
    const float sign = (d % 2) ? -1.f : 1.f;
    DRTV_CHECK(m.m00 == x.m00 && m.maa == x.maa && m.moo == x.moo && m.m0a == sign * x.m0a && m.ma0 == sign * x.ma0);
  }
  return {x.m00, x.m0a, x.ma0, x.maa, x.moo};
}

// One row of one step of one channel: the sums over the 6 directions of transmittance x matrix x
// the neighbour's 4 coefficients, grouped by matrix entry: each neighbour's 4 coefficients are
// scaled by its face's transmittance once (24 products), then each entry multiplies its sum of
// them (8 products), 71 operations per cell against 94 entry by entry. `mid`, `below`, `above`:
// the row's cell 0 in the previous step's slabs z, z-1, z+1, each with its 4 planes `sp` apart;
// `t`: the row of direction 0's transmittance, the others `st` apart (used when kOccluded);
// `out`, `acc`: the row of the step's slab and of the accumulation, planes `so` and `sacc` apart.
// With kFirst (step 1, which reads the injected grid) the accumulation is set to mid + the step
// instead of += the step: the same sum as copying the injected light first and adding, without
// the copy. kN > 0 fixes n (and so np and the strides of a grid of kN cells: kSrc, kDst 1 for a
// ring slot's planes (np^2 apart), 2 for a padded grid's (np^3), 0 for the run-time ones): every
// stream is then a base register and a constant offset, where with run-time strides the 34
// streams' pointers did not fit in the registers and were reloaded from the stack.
#if defined(__GNUC__)
#define DRTV_LPV_INLINE inline __attribute__((always_inline))  // into each clone, for its vector width
#else
#define DRTV_LPV_INLINE inline
#endif
template <bool kOccluded, bool kFirst, int kN, int kSrc, int kDst>
DRTV_LPV_INLINE void propagateRow(int n_rt, const StepConstants& k, const float* __restrict mid, const float* __restrict below,
                                  const float* __restrict above, ptrdiff_t sp_rt, const float* __restrict t, ptrdiff_t st_rt,
                                  float* __restrict out, ptrdiff_t so_rt, float* __restrict acc, ptrdiff_t sacc_rt,
                                  float* __restrict last) {
  constexpr auto planeStride = [](int kind, ptrdiff_t np) { return kind == 1 ? np * np : np * np * np; };
  const ptrdiff_t n = kN ? kN : n_rt;
  const ptrdiff_t np = n + 2;
  const ptrdiff_t sp = kN && kSrc ? planeStride(kSrc, np) : sp_rt;
  const ptrdiff_t so = kN && kDst ? planeStride(kDst, np) : so_rt;
  const ptrdiff_t st = kN ? n * n * n : st_rt, sacc = kN ? n * n * n : sacc_rt;
  // The outputs are other buffers than the inputs (restrict on these locals does not survive the
  // inlining, and 34 streams are more than GCC versions a loop for).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC ivdep
#endif
  for (ptrdiff_t i = 0; i < n; ++i) {
    // mid's, below's and above's planes: band 0, y, z, x (sh.h). Direction d's source: +x (d 0)
    // from i-1, -x from i+1, +y from the row j-1, -y from j+1, +z from slab z-1 (below), -z from
    // z+1 (above); f_d its face's transmittance.
    const float* m0 = mid;
    const float* my = mid + sp;
    const float* mz = mid + 2 * sp;
    const float* mx = mid + 3 * sp;
    const float f0 = kOccluded ? t[i] : 1.f, f1 = kOccluded ? t[st + i] : 1.f, f2 = kOccluded ? t[2 * st + i] : 1.f;
    const float f3 = kOccluded ? t[3 * st + i] : 1.f, f4 = kOccluded ? t[4 * st + i] : 1.f, f5 = kOccluded ? t[5 * st + i] : 1.f;
    auto sc = [](float f, float v) { return kOccluded ? f * v : v; };
    // Band 0 (u) and the direction's own axis coefficient (w), scaled.
    const float u0 = sc(f0, m0[i - 1]), u1 = sc(f1, m0[i + 1]), u2 = sc(f2, m0[i - np]), u3 = sc(f3, m0[i + np]);
    const float u4 = sc(f4, below[i]), u5 = sc(f5, above[i]);
    const float w0 = sc(f0, mx[i - 1]), w1 = sc(f1, mx[i + 1]), w2 = sc(f2, my[i - np]), w3 = sc(f3, my[i + np]);
    const float w4 = sc(f4, below[2 * sp + i]), w5 = sc(f5, above[2 * sp + i]);
    // Each band-1 coefficient's sum over the 4 directions across its axis.
    const float vx = (sc(f2, mx[i - np]) + sc(f3, mx[i + np])) + (sc(f4, below[3 * sp + i]) + sc(f5, above[3 * sp + i]));
    const float vy = (sc(f0, my[i - 1]) + sc(f1, my[i + 1])) + (sc(f4, below[sp + i]) + sc(f5, above[sp + i]));
    const float vz = (sc(f0, mz[i - 1]) + sc(f1, mz[i + 1])) + (sc(f2, mz[i - np]) + sc(f3, mz[i + np]));
    const float o0 = k.m00 * (((u0 + u1) + (u2 + u3)) + (u4 + u5)) + k.m0a * (((w0 - w1) + (w2 - w3)) + (w4 - w5));
    const float ox = k.ma0 * (u0 - u1) + k.maa * (w0 + w1) + k.moo * vx;
    const float oy = k.ma0 * (u2 - u3) + k.maa * (w2 + w3) + k.moo * vy;
    const float oz = k.ma0 * (u4 - u5) + k.maa * (w4 + w5) + k.moo * vz;
    out[i] = o0;
    out[so + i] = oy;
    out[2 * so + i] = oz;
    out[3 * so + i] = ox;
    if (kFirst) {
      acc[i] = m0[i] + o0;
      acc[sacc + i] = my[i] + oy;
      acc[2 * sacc + i] = mz[i] + oz;
      acc[3 * sacc + i] = mx[i] + ox;
    } else {
      acc[i] += o0;
      acc[sacc + i] += oy;
      acc[2 * sacc + i] += oz;
      acc[3 * sacc + i] += ox;
    }
  }
  if (last) std::copy_n(out, n, last);
}

// propagateRow with the strides fixed at compile time where they are the default grid's (32
// cells: a ring slot's planes or a padded grid's, the transmittances' and the accumulation's).
template <bool kOccluded, bool kFirst>
DRTV_LPV_INLINE void propagateRowAt(int n, const StepConstants& k, const float* mid, const float* below, const float* above,
                                    ptrdiff_t sp, const float* t, ptrdiff_t st, float* out, ptrdiff_t so, float* acc,
                                    ptrdiff_t sacc, float* last) {
  constexpr ptrdiff_t kS = 34 * 34, kP = 34 * 34 * 34, kCells = 32 * 32 * 32;
  if (n == 32 && (!kOccluded || st == kCells) && sacc == kCells && (sp == kS || sp == kP) && (so == kS || so == kP)) {
    if (sp == kS && so == kS) propagateRow<kOccluded, kFirst, 32, 1, 1>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else if (sp == kS) propagateRow<kOccluded, kFirst, 32, 1, 2>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else if (so == kS) propagateRow<kOccluded, kFirst, 32, 2, 1>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
    else propagateRow<kOccluded, kFirst, 32, 2, 2>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
  } else {
    propagateRow<kOccluded, kFirst, 0, 0, 0>(n, k, mid, below, above, sp, t, st, out, so, acc, sacc, last);
  }
}

// One propagation step of one channel on one slab z: dst = sum over the 6 directions of
// transmittance x matrix x the neighbour's 4 coefficients (lpv.h, "Propagation"), the neighbours
// read from the previous step's slabs z-1 (`below`), z (`mid`) and z+1 (`above`).
// `tr[d]`: the unpadded transmittance plane of direction d at slab z (null: no occlusion);
// `light[q]`: the unpadded accumulation at slab z, += the step (with `first`, step 1: = mid + the
// step); `light_lit`: its n row flags; `last`: null, or the unpadded band-0 slab that receives
// the step (the last one), with its n row flags `last_lit` (0: the row holds zeros).
// Rows are skipped when neither they nor their 4 neighbour rows hold light in the previous step.
// AVX-512 or AVX2 where the CPU has it (no FMA: -ffp-contract=off, so the same bits as SSE2).
DRTV_SIMD_CLONES
void propagateSlab(int n, const Slab& below, const Slab& mid, const Slab& above, const Slab& dst,
                   const std::array<const float*, kDirs>& tr, const std::array<float*, 4>& light, uint8_t* light_lit,
                   bool first, float* last, uint8_t* last_lit) {
  static const StepConstants k = stepConstants();
  const ptrdiff_t np = n + 2;
  // Every stream's planes evenly apart (the previous step's 3 slabs alike): propagateRow takes
  // one base and one stride per stream.
  const ptrdiff_t sp = mid.q[1] - mid.q[0], so = dst.q[1] - dst.q[0], sacc = light[1] - light[0];
  const ptrdiff_t st = tr[0] ? tr[1] - tr[0] : 0;
  for (int q = 1; q < 4; ++q)
    DRTV_CHECK(mid.q[size_t(q)] - mid.q[0] == q * sp && below.q[size_t(q)] - below.q[0] == q * sp &&
               above.q[size_t(q)] - above.q[0] == q * sp && dst.q[size_t(q)] - dst.q[0] == q * so &&
               light[size_t(q)] - light[0] == q * sacc);
  for (int d = 1; d < kDirs; ++d) DRTV_CHECK(tr[0] ? tr[size_t(d)] - tr[0] == d * st : !tr[size_t(d)]);
  for (int j = 0; j < n; ++j) {
    const size_t row_u = size_t(n) * size_t(j);
    const size_t row_p = size_t(1 + np * (j + 1));
    const size_t r = size_t(j + 1);
    if (!(mid.lit[r] | mid.lit[r - 1] | mid.lit[r + 1] | below.lit[r] | above.lit[r])) {
      if (dst.lit[r]) {  // what the slot held three slabs ago
        for (int q = 0; q < 4; ++q) std::fill_n(dst.q[size_t(q)] + row_p, n, 0.f);
      }
      dst.lit[r] = 0;
      if (first) {  // mid's row is zero: so is the light's (it may hold the last update's)
        if (light_lit[j])
          for (int q = 0; q < 4; ++q) std::fill_n(light[size_t(q)] + row_u, n, 0.f);
        light_lit[j] = 0;
      }
      if (last && last_lit[j]) {
        std::fill_n(last + row_u, n, 0.f);
        last_lit[j] = 0;
      }
      continue;
    }
    dst.lit[r] = 1;
    light_lit[j] = 1;
    if (last) last_lit[j] = 1;
    float* last_row = last ? last + row_u : nullptr;
    const float* m = mid.q[0] + row_p;
    const float* bl = below.q[0] + row_p;
    const float* ab = above.q[0] + row_p;
    const float* t = tr[0] ? tr[0] + row_u : nullptr;
    float* out = dst.q[0] + row_p;
    float* acc = light[0] + row_u;
    if (t) {
      DRTV_CHECK(!first);  // occlusion starts at step 2
      propagateRowAt<true, false>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    } else if (first) {
      propagateRowAt<false, true>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    } else {
      propagateRowAt<false, false>(n, k, m, bl, ab, sp, t, st, out, so, acc, sacc, last_row);
    }
  }
}


// The steps the two-thread pipeline's first job makes (propagate): 5/8 of them, not half: light
// spreads a cell per step, so later steps have more rows to make. On the benchmark's ground (3
// cascades, occlusion on, one thread) 4, 5 and 8 steps took 0.84, 1.18 and 2.18 ms: half the
// steps left the second job 61 % of the work, 5 of 8 leave it 46 %.
int pipelineFront(int iterations) { return std::clamp((iterations * 5 + 4) / 8, iterations - kWaveDepth, kWaveDepth); }

}  // namespace

void CascadedLpv::propagateJob(int c, int job, int worker, bool pipelined) {
  Cascade& g = cascades_[size_t(c)];
  const int n = g.n;
  const size_t N = g.cells;
  const size_t np = size_t(n) + 2, P = g.padded(), S = np * np;
  const int iterations = options_.iterations;
  // Within a channel, the steps are made in sweeps over the slabs of z (temporal blocking): at
  // time t, step s makes slab t - s from step s - 1's slabs t - s - 1 .. t - s + 1, the last of
  // them made at the same t, so each step needs only a ring of its last 3 slabs, and the injected
  // light, the accumulation and the transmittances are read once per sweep instead of once per
  // step (a step over a whole grid moved about 8 MB through a cache too small for it). The
  // accumulation takes every cell's steps in order, and each step's arithmetic is the whole-grid
  // step's, so the bits are the same as step by step, however the steps are cut into sweeps.
  auto lightPlanes = [&](int ch) {
    std::array<float*, 4> light;
    for (int q = 0; q < 4; ++q) light[size_t(q)] = g.light.data() + size_t(ch * 4 + q) * N;
    return light;
  };
  auto lightLit = [&](int ch, int z) { return g.light_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n); };
  auto injectedSlab = [&](int ch, int z) {
    Slab v;
    for (int q = 0; q < 4; ++q) v.q[size_t(q)] = g.injected.data() + size_t(ch * 4 + q) * P + size_t(z + 1) * S;
    v.lit = g.inj_lit.data() + (size_t(z + 1) * 3 + size_t(ch)) * np;
    return v;
  };
  auto startLight = [&](int ch, int z) {  // light = injected, slab z (rows without light: zeros)
    const Slab v = injectedSlab(ch, z);
    const std::array<float*, 4> light = lightPlanes(ch);
    uint8_t* lit = lightLit(ch, z);
    for (int j = 0; j < n; ++j) {
      const size_t row_p = 1 + np * size_t(j + 1);
      if (v.lit[j + 1]) {
        for (int q = 0; q < 4; ++q) std::copy_n(v.q[size_t(q)] + row_p, n, light[size_t(q)] + g.index(0, j, z));
      } else if (lit[j]) {
        for (int q = 0; q < 4; ++q) std::fill_n(light[size_t(q)] + g.index(0, j, z), n, 0.f);
      }
      lit[j] = v.lit[j + 1];
    }
  };
  auto gridSlab = [&](StepGrid& grid, int z) {  // a padded grid's slab z in [-1, n]
    Slab v;
    for (int q = 0; q < 4; ++q) v.q[size_t(q)] = grid.planes.data() + size_t(q) * P + size_t(z + 1) * S;
    v.lit = grid.lit.data() + size_t(z + 1) * np;
    return v;
  };
  // Steps done + 1 .. done + depth (<= kWaveDepth) of channel ch in one sweep on worker w's ring:
  // step `done` read from `from` (the injected grid if null), the sweep's last step written into
  // `to` (if not null) for a later sweep. ready(t) returns once `from`'s slabs up to t are made
  // (t < n); made(z) says that the sweep's last step has made slab z.
  auto sweep = [&](int ch, Scratch& w, int done, int depth, StepGrid* from, StepGrid* to, const auto& ready,
                   const auto& made) {
    const std::array<float*, 4> light = lightPlanes(ch);
    auto ringSlab = [&](int s, int z) {  // step s (1..kWaveDepth) of the sweep, slab z in [-1, n]
      const size_t slot = size_t(s - 1) * 3 + size_t(z + 1) % 3;
      Slab v;
      for (int q = 0; q < 4; ++q) v.q[size_t(q)] = w.ring.data() + (slot * 4 + size_t(q)) * S;
      v.lit = w.ring_lit.data() + slot * np;
      return v;
    };
    auto slab = [&](int s, int z) {
      if (s == 0) return from ? gridSlab(*from, z) : injectedSlab(ch, z);
      if (s == depth && to) return gridSlab(*to, z);
      return ringSlab(s, z);
    };
    for (int t = 0; t < n + depth; ++t) {
      if (t < n) ready(t);  // step 1 reads slab t of step `done` now
      for (int s = 1; s <= depth; ++s) {
        const int z = t - s;
        if (z < -1 || z > n) continue;
        if (z == -1 || z == n) {
          // Step s's slabs beyond the grid, read by step s + 1: zero (a grid's border always is).
          if (s < depth) clearSlab(n, ringSlab(s, z));
          continue;
        }
        const int step = done + s;
        std::array<const float*, kDirs> tr{};
        if (options_.occlusion && step >= 2)
          for (int d = 0; d < kDirs; ++d) tr[size_t(d)] = g.face_t.data() + size_t(d) * N + size_t(z) * size_t(n) * size_t(n);
        std::array<float*, 4> acc;
        for (int q = 0; q < 4; ++q) acc[size_t(q)] = light[size_t(q)] + size_t(z) * size_t(n) * size_t(n);
        float* last = step == iterations ? g.last_step.data() + size_t(ch) * N + size_t(z) * size_t(n) * size_t(n) : nullptr;
        uint8_t* last_lit = g.last_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n);
        propagateSlab(n, slab(s - 1, z - 1), slab(s - 1, z), slab(s - 1, z + 1), slab(s, z), tr, acc, lightLit(ch, z), step == 1,
                      last, last_lit);
        if (s == depth) made(z);
      }
    }
  };
  auto always = [](int) {};
  Scratch& w = scratch_[size_t(worker)];
  if (!pipelined) {
    // A channel on one worker: sweeps of up to kWaveDepth steps; between two, one of the
    // worker's padded grids holds the earlier one's last step.
    const int ch = job;
    if (iterations == 0) {
      for (int z = 0; z < n; ++z) startLight(ch, z);
      std::fill_n(g.last_step.data() + size_t(ch) * N, N, 0.f);
      for (int z = 0; z < n; ++z) std::fill_n(g.last_lit.data() + (size_t(z) * 3 + size_t(ch)) * size_t(n), n, uint8_t(0));
    }
    StepGrid* from = nullptr;
    for (int done = 0; done < iterations;) {
      const int depth = std::min(kWaveDepth, iterations - done);
      StepGrid* to = nullptr;
      if (done + depth < iterations) {
        const int which = from == &w.grids[0] ? 1 : 0;
        w.grids[size_t(which)].allocate(n);
        to = &w.grids[size_t(which)];
      }
      sweep(ch, w, done, depth, from, to, always, always);
      done += depth;
      from = to;
    }
    return;
  }
  // The two-thread pipeline (propagate): job 0 makes the first `front` steps of every channel
  // into the pipeline's grids, job 1 the rest a slab behind.
  Pipeline& pl = *pipeline_;
  const int front = pipelineFront(iterations);
  for (int ch = 0; ch < 3; ++ch) {
    std::atomic<int>& made = pl.made[size_t(ch)];
    StepGrid* grid = &pl.grids[size_t(ch)];
    if (job == 0) {
      sweep(ch, w, 0, front, nullptr, grid, always, [&](int z) { made.store(z + 1, std::memory_order_release); });
    } else {
      auto ready = [&](int t) {
        const int need = std::min(t + 1, n);  // slabs 0 .. t: step 1 at t - 1 reads up to t
        for (int spins = 0; made.load(std::memory_order_acquire) < need; ++spins) {
          if (spins > 64) std::this_thread::yield();
        }
      };
      sweep(ch, w, front, iterations - front, grid, nullptr, ready, always);
    }
  }
}

void CascadedLpv::propagate(int c) {
  DRTV_CHECK(c >= 0 && c < cascadeCount());
  const int iterations = options_.iterations;
  if (!workers_) {
    for (int ch = 0; ch < 3; ++ch) propagateJob(c, ch, 0, false);
  } else if (scratch_.size() == 2 && iterations >= 2 && iterations <= 2 * kWaveDepth) {
    // Two threads: 3 channel jobs would keep one thread idle a third of the time. Instead a
    // pipeline: job 0 makes the first steps of every channel in one sweep, into a grid per
    // channel, and job 1 the rest in a sweep that follows it a slab behind (it waits on the
    // first's progress), so each thread does about half the work. Whichever thread takes job 1,
    // job 0 has been taken before it, so the wait always ends (one thread runs them in turn).
    for (int ch = 0; ch < 3; ++ch) {
      pipeline_->grids[size_t(ch)].allocate(cascades_[size_t(c)].n);
      pipeline_->made[size_t(ch)].store(0, std::memory_order_relaxed);
    }
    workers_->run(2, [&](int job, int worker) { propagateJob(c, job, worker, true); });
  } else {
    workers_->run(3, [&](int ch, int worker) { propagateJob(c, ch, worker, false); });
  }
}

void CascadedLpv::relight(std::span<const VplList> lists) {
  // The cascades named, in increasing order: one injection job each (jobs 0 .. R-1), then one
  // job per cascade and channel for the propagation (R .. 4R-1). Workers take jobs in index
  // order, so a cascade's injection has been taken before any of its channels: a channel job
  // that waits for it waits on a thread that is running it, and on one thread the jobs simply
  // run in order.
  std::array<int, 8> relit{};
  int R = 0;
  for (int c = 0; c < cascadeCount(); ++c) {
    bool named = false;
    for (const VplList& l : lists) {
      DRTV_CHECK(l.cascade >= 0 && l.cascade < cascadeCount());
      named |= l.cascade == c;
    }
    if (named) relit[size_t(R++)] = c;
  }
  if (R == 1 && workers_) {
    // One cascade: its injection would be one job on one thread, while injectLight splits it over
    // the threads (a camera step, the finest cascade alone: BM_LpvCameraStep 18.8-19.2 ms by the
    // calls against 22.8-23.9 ms as one job, 2026-12-02). The same bits either way (lpv.h).
    clearLight(relit[0]);
    for (const VplList& l : lists) injectLight(relit[0], l.surfels);
    propagate(relit[0]);
    return;
  }
  std::array<std::atomic<bool>, 8> injected{};
  auto job = [&](int i, int worker) {
    if (i < R) {
      const int c = relit[size_t(i)];
      // clearLight's injected half: propagate overwrites every row of the accumulation (light =
      // injected, then += each step), so clearing it first would change nothing.
      clearInjected(c);
      for (const VplList& l : lists)
        if (l.cascade == c) injectJob(c, l.surfels, 0, 1);
      injected[size_t(i)].store(true, std::memory_order_release);
      return;
    }
    const int r = (i - R) / 3, ch = (i - R) % 3;
    for (int spins = 0; !injected[size_t(r)].load(std::memory_order_acquire); ++spins) {
      if (spins > 64) std::this_thread::yield();
    }
    propagateJob(relit[size_t(r)], ch, worker, false);
  };
  if (!workers_) {
    for (int i = 0; i < 4 * R; ++i) job(i, 0);
  } else {
    workers_->run(4 * R, job);
  }
}

}  // namespace drtv::lpv
