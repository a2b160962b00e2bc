// drtv/baker/transfer.h — the transfer bake of one sector's probes: PRT for sun and sky bounce,
// sky visibility, and optionally LPRT, all through one surface-transfer cache.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 18-24.
//  [2] Sloan, Kautz, Snyder, "Precomputed Radiance Transfer for Real-Time Rendering in Dynamic,
//      Low-Frequency Lighting Environments", SIGGRAPH 2002 (transfer vectors, interreflections
//      by iterating a gather over surface samples, sec. 5).
//  [3] Kristensen, Akenine-Moeller, Jensen, "Precomputed Local Radiance Transfer for Real-Time
//      Lighting Design", SIGGRAPH 2005 (LPRT: point lights at fixed source positions).
//  [4] Pharr, Jakob, Humphreys, pbrt-v4, sec. 2.2 (Monte Carlo estimators), 2.4.2 (balance
//      heuristic / mixture sampling).
//  [5] Ward, Rubinstein, Clear, "A Ray Tracing Solution for Diffuse Interreflection",
//      SIGGRAPH 1988 (caching diffuse transfer at surface points and reusing it).
//
// What is computed, for probe position p, basis normal B_b (sh.h) and channel c (DESIGN.md):
//   T[c][b] = integral over the hemisphere about B_b of (rho_c(x)/pi) T_x(w) cos dw
// where x is the first hit along w and T_x is the SH4 transfer vector of surface point x:
//   T_x = integral of Y(w') V(x,w') max(0, n_x.w') dw'          (direct: sky seen from x)
//       + integral of (rho(y)/pi) T_y max(0, n_x.w') dw'        (bounces: y first hit from x)
// so that bounced irradiance at a surface facing B_b is dot(L_sh[c], T[c][b]) for any distant
// lighting L_sh (sun + sky) [2]. With cosine-weighted rays about B_b (pdf cos/pi [4]):
//   T[c][b] ~= (1/N) sum over front-face hits of rho_c(x_i) T_{x_i}[c].
// Sky visibility v[b] = the fraction of those rays that escape. sky_vis_sh = the SH projection of
// the 0/1 visibility over the sphere, estimated from all 4N rays with the mixture pdf of the four
// cosine lobes (the balance heuristic [4]). Back-face hits (a ray entering geometry) carry no
// light and count in backface_frac.
//
// The surface-transfer cache [5]: T_x is computed once per surface cell — a `surfel_cell_m` cube
// and one of six normal directions (the dominant axis of the front normal) — at one hit that
// landed in it (for level 1 the probe hit nearest the mean of the cell's probe hits, deeper the
// first hit; both in probe, basis, sample order, so the choice does not depend on threads), and
// reused by every probe ray and surfel ray that lands in the same cell. With `cell_sides` (sh-l1)
// a cell holds one surfel per side of the walls that cross it: a hit joins the first of its cell's
// surfels whose point, kCellSideOffsetM off its surface, sees the hit's point as far off its own
// (one short occlusion ray each), and starts a new one where none does; otherwise the floor of a
// room and the sunlit ground outside its wall, both facing up within one cube, share one transfer
// and the room reads the ground's light. Only cubes that static geometry reaches are split:
// terrain and vegetation alone are one side. Level 1
// surfels are the probes' hits, level k+1 the hits of level k's rays, up to `bounces` levels;
// each casts `surfel_rays` cosine-weighted rays. Then `bounces - 1` Jacobi sweeps of
// T_s = D_s + (1/M) sum rho T_child give every level-1 surfel `bounces` bounces [2]; rays from the
// last level that land in a cell not yet cached end the path there (truncation, a small
// darkening reported in docs/baker.md).
//
// LPRT [3] (only when sources are given): a unit white point light (radiant intensity 1 per sr)
// at each source position; for each level-1 surfel x, its direct irradiance
// E_j(x) = V(x, s_j) max(0, n_x.l) / max(d^2, kLprtMinDistance2) is traced once (rtcOccluded1M,
// one batch per surfel); then per probe, basis and source, one diffuse bounce:
//   LPRT[p][j][c][k] = (1/N) sum over basis-k rays' front hits of rho_c(x_i) E_j(x_i)
// i.e. the bounced irradiance on a surface facing B_k (sector.h's kSectorLprtOnBases layout).
// That is fc3, the talk's single bounce, kept bit for bit. sh-l1 (and a cube baked beside it)
// carries `bounces` bounces as T does: E_j is traced at every surfel of the cache, then
// `bounces - 1` Jacobi sweeps of B_s,c = E_s + (1/M) sum rho_c B_child,c over the cache's links
// (per channel: coloured walls tint what they pass on), and B takes E's place in the gather below
// (the path tracer carries every bounce; docs/runtime.md, "Local lights", measures the change).
// The light's direct contribution is the runtime's business and is not included.
//
// sh-l1 (representation.h): the same rays, weighed for the sphere instead of each basis' lobe.
// With all 4N rays of a probe and the mixture pdf p(w) = S(w) / (4 pi), S(w) = sum_k max(0, B_k.w)
// (>= 0.8 everywhere: the four lobes cover the sphere, so the estimator is bounded):
//   M[c][i][j] = integral Y_i(w) (rho_c(x)/pi) T_x[c][j] dw ~= 1/N sum rho_c(x) T_x[c][j] Y_i(w) / S(w)
// (the bounced radiance arriving at the probe, projected), sky_moments = 3/(4 pi) integral of
// (y z, z z, x z) V dw from the escaped rays, and the LPRT block in SH (on_bases = false):
//   LPRT[p][j][c][i] = 1/N sum rho_c(x) B_j,c(x) Y_i(w) / S(w).
// sky_vis keeps its kFc3 meaning (the distant-occlusion tile and the tools read it).
//
// The sun transfer (sh-l1 only; sector.h SunBlock): the linear sun lobe s(d) = 2 [0, Y1(d)]
// makes dot(D_x, s(d)) = n.d exactly on a surface point that sees the whole sky, but it ignores
// where the point is shadowed from d (a roof's shade on the ground, a wall's) and lights points
// facing away negatively. For each sun sample d_k along the world's sun path (sunSamples) and each
// level-1 surfel x, one shadow ray gives the exact direct sun irradiance
// E_k(x) = V(x, d_k) max(0, n_x.d_k); the correction to the probe's bounced radiance SH is
//   C[p][k][c][i] = 1/N sum rho_c(x) (E_k(x) - dot(D_x, s(d_k))) Y_i(w) / S(w)
// over the probe's 4N rays (the sh-l1 gather's weights), D_x the direct part of T_x. The sun's
// first bounce is then exact along the path; its later bounces stay those of the linear lobe.
//
// The ambient cube (issue 13, eval/techniques/ambient_cube; held in memory only, no archive format):
// six clamped-cosine lobes about the axes A_a = +x, -x, +y, -y, +z, -z, gathered from the same 4N
// rays of a probe with the sh-l1 mixture weights, max(0, A_a.w) / S(w) in place of Y_i(w) / S(w):
//   C[c][a]      = 1/N sum rho_c(x) T_x[c] max(0, A_a.w) / S(w)   (SH4: bounced irradiance facing A_a
//                                                                 is dot(L_sh[c], C[c][a]))
//   sky_h[a]     = 1/(4N) sum over escaped rays max(0, A_a.w) / p(w)          (integral of cos+ V)
//   sky_delta[a] = the same over escaped rays with w.z > 0, times sqrt(w.z)
// so that the direct sky facing A_a is exactly H sky_h + (Z - H) sky_delta for the world's sky
// model (probe.h's kProbeSkyFit; the cube stores the six values the sh-l1 fit fits). The sun
// correction and LPRT the same way: sun[p][k][c][a] = 1/N sum rho_c (E_k(x) - dot(D_x, s(d_k)))
// max(0, A_a.w) / S(w), lprt[p][j][c][a] = 1/N sum rho_c E_j(x) max(0, A_a.w) / S(w).
// Asking for it changes nothing else bakeTransfer returns.
// Determinism: ray directions are R2 points [pbrt sec. 8.2] (CosineSampler) with a shift keyed by (seed, sector,
// probe, basis) or (seed, sector, surfel index); all sums run in a fixed order.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/lighting.h"
#include "drtv/formats/probe.h"
#include "drtv/formats/representation.h"

namespace drtv::baker {

// LPRT's 1/d^2 is clamped at 1 m: a light closer than that to a surface would otherwise blow a
// single cache cell up into a firefly that the 2 m cells cannot resolve anyway.
inline constexpr float kLprtMinDistance2 = 1.f;

// How far off their surfaces two hits of one cache cell are tested for seeing each other
// (TransferSettings::cell_sides): above a kerb or a skirting board, below any wall, and the sagitta
// of a 2.8 m chord (a 2 m cell's diagonal) over a hill of 3.9 m radius, so that open terrain,
// gently curved, stays one surfel a cell.
inline constexpr float kCellSideOffsetM = 0.25f;

struct TransferSettings {
  int probe_rays_per_basis = 256;  // N: cosine-weighted rays per basis direction and probe
  int surfel_rays = 32;            // M: rays per cached surface cell
  float surfel_cell_m = 2.f;       // edge of a surface cache cell, metres
  int bounces = 2;                 // diffuse bounces in T (>= 1): levels of the cache traced
  // Jacobi sweeps over the cache's links (0: bounces - 1, each level's bounce once). More sweeps
  // than levels carry further bounces around the links that close on cells already cached (a
  // room's walls light each other), with no more rays; bounded by it, since the energy of a
  // closed room of albedo 1 never converges. The presets sweep kPresetSweeps times (2026-12-07).
  int sweeps = 0;
  // The same for LPRT's local light (0: bounces - 1). Apart from `sweeps` since 2026-12-07: each of
  // its sweeps carries every source's light (up to 128 a sector), and 4 of them made the lit 150 m
  // town's bake 1.5x as long, where the sun and sky's cost nothing measurable.
  int lprt_sweeps = 0;
  // A cache cell splits where a wall separates the hits that land in it (above; sh-l1 only: fc3
  // keeps the talk's bytes). false: one surfel per cube and normal direction, the archives of
  // every build before 2026-12-03 byte for byte (`drtv bake --cache-cells shared`).
  bool cell_sides = true;
  bool prt = true;                 // bake T (sun or sky bounce asked for); else T = 0
  bool sky_visibility = true;      // bake v and sky_vis_sh (direct sky asked for); else 0
  uint64_t seed = 1;
  Representation representation = Representation::kShL1;  // what prt and LPRT hold (see above); new worlds: sh-l1 (docs/accuracy.md)
  int sun_samples = 6;  // sun-transfer samples along the sun path (sh-l1; 0 = none), <= kMaxSunSamples
};

// The Jacobi sweeps a bake with `s` runs (TransferSettings::sweeps).
inline int sweepCount(const TransferSettings& s) { return s.sweeps > 0 ? s.sweeps : s.bounces - 1; }
// LPRT's (TransferSettings::lprt_sweeps).
inline int lprtSweepCount(const TransferSettings& s) { return s.lprt_sweeps > 0 ? s.lprt_sweeps : s.bounces - 1; }
// The presets' sweeps (BakeSettings::forQuality): measured 2026-12-07 on the shared assets, the
// same points each (drtv accuracy --stratify, 1 -> 4 sweeps): pandora 49.0 -> 37.5 %, zdm2 18.9 ->
// 17.0 %, the 150 m town 8.9 -> 8.6 %, the Cornell world 17.0 -> 16.7 %; the island 9.0 -> 9.3 %,
// living_room 24.6 -> 24.8 %. 16 converge (pandora 36.7 %) for no further gain elsewhere.
inline constexpr int kPresetSweeps = 4;


// The linear sun lobe per unit irradiance from unit direction `d`: 2 [0, Y1(d)] (lighting_sh.h's
// projectSun with band1_window 2, band0_scale 0).
sh::Sh4 linearSunLobe(const glm::vec3& d);

// `count` unit directions towards the sun along `sky`'s path, from sunrise to sunset at equal
// hour steps (both ends on the horizon, z clamped to 0), or over the whole day when the sun never
// sets; none when it never rises or count < 2. Thread-safe.
std::vector<glm::vec3> sunSamples(const Sky& sky, int count);

inline constexpr int kCubeAxes = 6;
// Axis a of the ambient cube: +x, -x, +y, -y, +z, -z.
glm::vec3 cubeAxis(int a);

struct CubeTransfer {
  std::vector<std::array<std::array<sh::Sh4, kCubeAxes>, 3>> prt;  // [probe][channel][axis]
  std::vector<std::array<float, kCubeAxes>> sky_h, sky_delta;       // [probe][axis]
  std::vector<float> sun;   // [probe][sun sample][channel][axis] (empty without sun directions)
  std::vector<float> lprt;  // [probe][source][channel][axis] (empty without sources)
};

struct TransferStats {
  uint64_t probe_rays = 0;    // probes' basis rays and height rays
  uint64_t surfel_rays = 0;   // rays of the surface cache
  uint64_t lprt_rays = 0;     // LPRT shadow rays
  uint64_t sun_rays = 0;      // sun-transfer shadow rays
  size_t surfels = 0;         // cache cells traced
  size_t probe_hits_cached = 0;  // probe rays that reused a cell another ray had created
  double probe_seconds = 0, surfel_seconds = 0, lprt_seconds = 0, sun_seconds = 0;  // thread-time of each stage
};

// Bakes `probes` (positions in `geometry`'s local frame, which is sector-relative) against
// `scene`, built over `geometry`. Returns one ProbeData per probe with position, prt, sky_vis,
// sky_vis_sh, backface_frac, height_m and mean_hit_m filled (flags and interior left 0).
// When `lprt_sources` is non-empty, `lprt` receives probes.size() x sources x 3 x 4 floats in
// LprtBlock order ([probe][source][channel][basis]). When `sun_directions` is non-empty, the
// representation sh-l1 and PRT on, `sun` receives probes.size() x samples x 3 x 4 floats in
// SunBlock order (the correction above); else it is emptied. When `cube` is given it receives
// the ambient cube's transfer (above) for every probe, its sun correction for `sun_directions`
// (with PRT on, in any representation) and its LPRT for `lprt_sources` (`lprt` may then be
// null). Uses TBB inside; the result does not depend
// on the number of threads. Thread-safe (reads only its arguments).
std::vector<ProbeData> bakeTransfer(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry,
                                    std::span<const glm::vec3> probes, const TransferSettings& settings,
                                    TransferStats& stats, std::span<const glm::vec3> lprt_sources = {},
                                    std::vector<float>* lprt = nullptr, std::span<const glm::vec3> sun_directions = {},
                                    std::vector<float>* sun = nullptr, CubeTransfer* cube = nullptr);

}  // namespace drtv::baker
