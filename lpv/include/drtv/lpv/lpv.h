// drtv/lpv/lpv.h — Cascaded Light Propagation Volumes: reflective-shadow-map texels in, ambient
// irradiance out. The engine-facing half of drtv's second GI technique (DESIGN.md, "Techniques
// side by side"): GLM and drtv::formats only, no Embree. Where the RSM texels come from (a GPU
// rasteriser in an engine, drtv's ray caster in eval/techniques/lpv) is the caller's business.
//
// References
//  [1] Kaplanyan & Dachsbacher, "Cascaded Light Propagation Volumes for Real-Time Indirect
//      Illumination", I3D 2010, and Kaplanyan, "Light Propagation Volumes in CryEngine 3",
//      SIGGRAPH 2009 course (../shared/seeds/003): injection (sec. 4.1), propagation (sec. 4.2,
//      fig. 3), fuzzy occlusion (sec. 4.3), cascades (sec. 5).
//  [2] ../shared/seeds/002: the clamped cosine lobe in SH, in a convention with the Condon-Shortley
//      phase (Y1-1 = -0.4886 y, Y11 = -0.4886 x). `fromSeed002` converts.
//  [3] Ramamoorthi & Hanrahan 2001 (sh.h): the clamped-cosine convolution.
//
// Quantities (one definition, used by every function here):
//  - A cell holds, per colour channel, the band-1 SH (sh.h's order and signs) of the radiance of
//    light TRAVELLING in direction w through it, L(w) [per sr, the sky's units]. A point light of
//    radiant intensity I(w) spread over a cell of side s stands for radiance I(w) / s^2 (the
//    paper's intensity-to-radiance step [1] sec. 4.2).
//  - A VPL (RSM texel) of reflected flux Phi with normal n is a Lambertian emitter of intensity
//    Phi / pi * max(0, n.w): it adds Phi / (pi s^2) * cosineLobe(n) to its cell, the cell found
//    half a cell along n from the texel (the paper's shift against self-lighting [1] sec. 4.1).
//  - Irradiance at a surface with unit normal n from the light travelling through the point:
//    E(n) = integral L(w) max(0, -n.w) dw = dot(cosineLobe(-n), L) (light arriving from -w).
//  - Propagation [1] fig. 3: each cell gathers from its 6 face neighbours; the light a neighbour
//    sends through each of the 5 faces of the receiving cell it sees (the far face, solid angle
//    kFarFaceSolidAngle, and 4 side faces, kSideFaceSolidAngle each, seen from the neighbour's
//    centre) is flux dw_f * L(w_f) towards the face centre, re-emitted from the receiving cell's
//    centre as a cosine lobe about the face's outward normal: + dw_f L(w_f) / pi * cosineLobe(n_f).
//    Over the 30 faces the solid angles sum to 4 pi, so a step in empty space keeps every band-0
//    coefficient: the flux of a cell's light, sqrt(4 pi) c0, leaves it whole (the tests check it;
//    band-1 evaluation can make a face's flux negative, which is kept, not clamped, so energy is
//    conserved exactly; only the grid's borders lose light). The result is the sum of the
//    injected grid and every step's output; each step reads the previous step's output only.
//  - Fuzzy occlusion [1] sec. 4.3: a geometry volume on the cell corners (the LPV offset by half
//    a cell) holds the SH of the blocking potential B(w) of the surfaces in each corner cell: a
//    surfel of area A and normal n adds A / s^2 * cosineLobe(n), so that light travelling in
//    direction t is blocked by dot(B, Y(-t)) clamped to [0, 1] (a surface blocks light arriving
//    on its front side). From the second step on, the light crossing a face is scaled by
//    1 - blocking at that face's centre (the mean of its 4 corners) for the neighbour direction.
//  - Sky light (the talk's sky, with what occlusion an LPV can offer: the same geometry volume).
//    For each cell, transmittance along kSkyDirections directions w is marched through the
//    geometry volume of its own cascade, blocked as a ray from the cell travelling along w is
//    (by the surfaces it meets on their front side, as the path tracer's rays are) (one cell per step, up to sky_steps cells: occluders
//    farther than that, or outside the cascade, do not shadow it); the visible sky radiance's
//    SH is then sum_k L_sky(w_k) T_k Y(w_k) 4pi/K, and its irradiance dot(cosineLobe(n), sky).
//    It is an ambient-occlusion-like estimate, not light transport: no sky bounce comes from it
//    (the technique injects sky-lit surfels for that).
//  - Lookup: the light at the point moved lookup_offset_cells along the normal, trilinear over
//    cell centres. With `damping` (seed 003's damping of self-bleeding: the light's direction
//    against the normal), the irradiance is scaled by 1 - max(0, n.d) per channel, d the unit
//    band-1 direction of the light there: light a surface receives travels towards it, so light
//    travelling out of it is its own or its plane's, which band 1's wide lobe would otherwise
//    read (an up-facing ground under a lit plane's light: +20 % under a uniform sky without it).
//  - Cascades [1] sec. 5: nested grids of `cells`^3, cell size cell_m * ratio^c, centred on the
//    camera and snapped to whole cells so that light does not swim; each is an independent LPV
//    (its own injection, occlusion and propagation); lookups use the finest cascade holding the
//    point and blend to the next over `blend_cells` cells at its border.
//
// Threading: one thread drives a CascadedLpv (setCamera, inject*, propagate, computeSky);
// injectLight() and propagate() may use `threads` - 1 workers of its own (started with the
// object, asleep between calls); the const lookups may run from any number of threads between
// those calls.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/formats/sh.h"

namespace drtv::lpv {

// The solid angles of a cell's faces seen from the centre of a face neighbour (cell side 1, the
// neighbour's centre 1 away from the receiving cell's centre) [1] sec. 4.2: the far face and one
// of the 4 side faces. Every ray through the shared face leaves through one of these 5, so they
// sum to the shared face's 2 pi / 3 (a cube face seen from the cube's centre); the tests compute
// both from the exact rectangle formula. (The commonly copied 0.4234413544 is a digit typo.)
inline constexpr float kFarFaceSolidAngle = 0.4006696846f;
inline constexpr float kSideFaceSolidAngle = 0.4234313544f;

// The directions along which each cell's sky transmittance is marched (a spherical Fibonacci
// set over the whole sphere: the sky below the horizon is the world's ground radiance).
inline constexpr int kSkyDirections = 16;

// Converts a band-1 SH vector in seed 002's convention (Condon-Shortley phase: Y1-1 = -c y,
// Y11 = -c x) to sh.h's: the y and x coefficients change sign. Its own inverse.
inline sh::Sh4 fromSeed002(const sh::Sh4& s) { return {s.x, -s.y, s.z, -s.w}; }

// One surface sample: an RSM texel (a VPL and an occluder) or a geometry sample (an occluder).
struct Surfel {
  glm::dvec3 position{0.0};  // world metres, on the surface
  glm::vec3 normal{0.f, 0.f, 1.f};  // unit, the lit (front) side
  glm::vec3 flux{0.f};       // reflected flux leaving the surfel, linear RGB [sky units x m^2]
  float area_m2 = 0.f;       // surface area the sample stands for (blocking potential)
};

struct LpvOptions {
  int cascades = 3;            // nested grids, [1, 8]
  int cells = 32;              // cells per axis of each grid, even, [4, 128]
  double cell_m = 1.0;         // cell side of the finest cascade, metres, (0, 1e4]
  double ratio = 2.0;          // cell side ratio between consecutive cascades, [1.5, 4]
  int iterations = 8;          // propagation steps per update, [0, 256]
  bool occlusion = true;       // fuzzy occlusion from the second step on
  int sky_steps = 12;          // cells marched per sky direction, [0, cells]
  float lookup_offset_cells = 0.5f;  // the lookup point moves this far along the normal, cells
  float blend_cells = 3.f;     // width of the blend to the next cascade at a cascade's border, cells
  bool damping = true;         // damping of self-bleeding at lookups (indirect(); lpv.h, "Lookup")
  int threads = 1;             // threads injectLight (blocks of rows) and propagate run on, [1, 64]
                               // (propagate: one colour channel each, at most 3; on 2, each
                               // thread about half of every channel's steps); the same bits for any count
};
// What is wrong with `o`, as an error naming the field (nothing when it is sound).
Result<void> validate(const LpvOptions& o);

// One cascade's placement: world position of its min corner, cell side and cells per axis.
struct CascadeBox {
  glm::dvec3 min{0.0};
  double cell_m = 1.0;
  int cells = 0;
  glm::dvec3 max() const { return min + glm::dvec3(cell_m * cells); }
  bool contains(const glm::dvec3& p) const {
    const glm::dvec3 hi = max();
    return p.x >= min.x && p.y >= min.y && p.z >= min.z && p.x < hi.x && p.y < hi.y && p.z < hi.z;
  }
};

// One list of VPLs for CascadedLpv::relight: `surfels` (as injectLight takes them) for cascade
// `cascade`. The surfels are not copied: they must outlive the call.
struct VplList {
  int cascade = 0;                  // [0, cascadeCount())
  std::span<const Surfel> surfels;  // RSM texels, their flux
};

class CascadedLpv {
 public:
  // Errors: `validate(options)`'s.
  static Result<CascadedLpv> create(const LpvOptions& options);

  const LpvOptions& options() const { return options_; }
  int cascadeCount() const;
  // Where cascade `c` lies now (a bug for c out of range).
  const CascadeBox& box(int c) const;

  // Centres every cascade on `camera` (world metres, finite), snapped to whole cells of that
  // cascade. Returns a bit per cascade whose box moved (all, the first time): their light,
  // geometry and sky are cleared and must be injected and computed again.
  uint32_t setCamera(const glm::dvec3& camera);

  // Clears cascade c's light (before injecting a new lighting).
  void clearLight(int c);
  // Adds the VPLs `surfels` (their flux) to cascade c; those outside it are ignored.
  void injectLight(int c, std::span<const Surfel> surfels);
  // Clears cascade c's geometry volume, then adds the blocking potential of `surfels` (their
  // area). Call computeOcclusion(c) after the last injectGeometry.
  void clearGeometry(int c);
  void injectGeometry(int c, std::span<const Surfel> surfels);
  // Per-face transmittances from the geometry volume, and the sky transmittance of every cell.
  void computeOcclusion(int c);
  // The visible sky's radiance SH per cell from the transmittances and `sky_radiance(w)` (linear
  // RGB per sr arriving from unit direction w). Needs computeOcclusion(c) since the last move.
  template <class F>
  void computeSky(int c, F&& sky_radiance) {
    std::array<glm::vec3, kSkyDirections> L;
    for (int k = 0; k < kSkyDirections; ++k) L[size_t(k)] = sky_radiance(skyDirection(k));
    setSkyRadiance(c, L);
  }
  // Runs `iterations` propagation steps on cascade c and stores their sum with the injected light.
  void propagate(int c);
  // A whole update of the light in one call: every cascade named in `lists` gets clearLight,
  // then injectLight of each of its lists in the order given, then propagate, with the same bits
  // as those calls (on any thread count); the other cascades are left alone. On more than one
  // thread the jobs are the cascades' injections and then their channels' propagations, each
  // channel as soon as its cascade's injection is done (the cascades are independent grids), in
  // one wake-up of the workers instead of two per cascade, and each injection reads only its own
  // cascade's surfels (injectLight on threads reads every surfel once per thread). A bug for a
  // cascade out of range. A single cascade on threads is relit by those calls (its injection then
  // splits over the threads).
  void relight(std::span<const VplList> lists);

  // The propagated (indirect) irradiance at world `position` for unit `normal`, linear RGB,
  // blended over cascades; 0 outside every cascade. Negative SH results are clamped to 0.
  glm::vec3 indirect(const glm::dvec3& position, const glm::vec3& normal) const;
  // The visible sky's irradiance there (computeSky), clamped to >= 0.
  glm::vec3 sky(const glm::dvec3& position, const glm::vec3& normal) const;
  // The same from cascade c alone (trilinear, clamped to its border cells; no blend): the
  // technique's sky-lit surfels, and the tests' comparison of cascades.
  glm::vec3 indirectIn(int c, const glm::dvec3& position, const glm::vec3& normal) const;
  glm::vec3 skyIn(int c, const glm::dvec3& position, const glm::vec3& normal) const;

  // The light SH of cascade c's cell (i, j, k) after propagate, per channel (tests).
  sh::Sh4Rgb cellLight(int c, int i, int j, int k) const;
  // The sum of band-0 coefficients of cascade c's accumulated light (flux-like, tests), and of
  // the light the last propagation step produced.
  glm::dvec3 totalLight(int c) const;
  glm::dvec3 lastStepLight(int c) const;
  // The sky direction k of the march (unit).
  static glm::vec3 skyDirection(int k);
  // Bytes the cascades keep between updates (light, geometry, transmittances, sky) and the
  // scratch a propagation needs.
  size_t bytes() const;

 private:
  struct Cascade;
  explicit CascadedLpv(const LpvOptions& o);
  void setSkyRadiance(int c, const std::array<glm::vec3, kSkyDirections>& L);
  // clearLight's half for the injected grid.
  void clearInjected(int c);
  // Adds the surfels landing in rows j of cascade c with (j / 4) % jobs == job (injectLight).
  void injectJob(int c, std::span<const Surfel> surfels, int job, int jobs);
  // propagate's work on cascade c with worker `worker`'s scratch: channel `job`'s steps, or (if
  // `pipelined`) job `job` of the two-thread pipeline, which propagate sets up.
  void propagateJob(int c, int job, int worker, bool pipelined);
  glm::vec3 lookup(int c, const glm::dvec3& position, const glm::vec3& normal, bool sky) const;
  glm::vec3 blended(const glm::dvec3& position, const glm::vec3& normal, bool sky) const;

  LpvOptions options_;
  std::vector<Cascade> cascades_;
  // Propagation scratch, one per thread (lpv.cpp), shared by the cascades; the workers; with
  // two threads, the grids between the halves of a propagation's steps.
  struct Scratch;
  class Workers;
  struct Pipeline;
  std::vector<Scratch> scratch_;
  std::unique_ptr<Workers> workers_;
  std::unique_ptr<Pipeline> pipeline_;
  bool placed_ = false;

 public:
  CascadedLpv(CascadedLpv&&) noexcept;
  CascadedLpv& operator=(CascadedLpv&&) noexcept;
  ~CascadedLpv();
};

}  // namespace drtv::lpv
