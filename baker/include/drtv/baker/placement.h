// drtv/baker/placement.h — automatic probe placement for one sector (talk [1] slides 15-16).
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012.
//
// The rule, step by step (all deterministic; no dependence on threads or on other sectors):
//  1. Static pass [1, slide 15]: vertical rays every `column_spacing_m` (4 m) at the centres of a
//     grid over the sector, cast down from above all geometry. Every front-face hit on terrain or
//     static geometry along the ray — not only the first — is a candidate, lifted by
//     min(lift_m, half the gap to the static surface above it). Vegetation triangles are passed
//     through (their leaves give noisy heights [1, slide 16]). A hit under a surface less than
//     2 clearance_m above it (a building resting 2 cm above the ground, a slab on short legs) is
//     no candidate: a probe there would see nothing but the two surfaces (issue 16). Under a
//     static surface a space taller than a storey gives more candidates above the first, every
//     `covered_stack_m` (a hall's ceiling 6 m over its floor keeps a probe near it, issue 35).
//     If no column of a sector finds static geometry but static triangles overlap the sector
//     (an object smaller than the spacing, between columns), one more column is cast through the
//     centre of their bounds clipped to the sector, so that a lone small object gets a probe.
//  2. Vegetation pass [1, slide 16]: rays every `vegetation_spacing_m` (8 m) against the bounding
//     box of each vegetation instance; a candidate on top of every box the ray hits, lifted.
//  3. Interiors (only when the world asks for them): the designated probe of every interior
//     volume whose position lies in the sector, kept unconditionally.
//  4. Inside test: `inside_test_rays` rays in all directions, at most `inside_test_range_m` long;
//     a candidate whose hits include many back faces (> kInsideBackfaceFraction) is inside geometry
//     (under terrain inside a rock, inside a floor slab). It is moved to the first of a fixed list
//     of offsets (up 0.5/1/2/4 m, then sideways 1/2 m) that passes the test and flagged
//     kProbeRelocated; if none passes it is dropped. A covered candidate is not moved to within
//     clearance_m of the surface above its column hit, or past it (into the storey above, onto
//     the roof, still flagged covered; `covered_stays_under`). The same test's rays measure the nearest
//     static surface, and a candidate nearer than clearance_m to one (a column landing beside a
//     wall) is moved the same way, or dropped. Counted in PlacementStats.
//     Under roofs (covered hits) the columns are also cast on the finer `covered_column_spacing_m`
//     lattice; of those columns only the covered hits are candidates. After the vegetation pass,
//     columns on the `enclosed_column_spacing_m` lattice give candidates that are covered and
//     enclosed (kEnclosedWalls of kEnclosedRays horizontal rays meet static walls) only.
//  5. Minimum distance: candidates are taken greedily in priority order — interior designated,
//     covered static hits (under a roof or overhang: rarer, and the only probes indoors), first
//     static hits, vegetation; ties in column order — and a candidate is rejected when an accepted
//     probe lies within `min_horizontal_m` (a covered one: `covered_min_horizontal_m`; an
//     enclosed one: `enclosed_min_horizontal_m`) horizontally AND `min_vertical_m` vertically
//     (a cylinder: floors stacked 3 m apart keep their own probes). Where one of the two is
//     covered, only if no static surface stands between them (`covered_sight`): a roof and the
//     room under it, or two rooms either side of a wall, keep a probe each.
//  6. Cap: a sector holds at most 255 probes (one-byte index [1, slide 17]), less the light
//     sources of step 7. If step 5 accepts more, it is repeated with the least distances x 1.25
//     until few enough remain (thinning evenly rather than dropping a region): the enclosed and
//     covered ones first, up to the open one (`thin_near_first`), then all three; designated
//     interior probes are always kept. Probes that do not see each other are kept apart past
//     their step-5 distance (`covered_sight` waives only that), so a block of rooms thins too.
//  7. Light sources (LPRT bakes only, issue 35): a probe at the position of each given light
//     under static geometry (a ray straight up from it meets a static surface: indoors, under a
//     roof or an overhang), as given (no relocation: a lamp hangs against its fitting), flagged
//     kProbeLightSource and appended after the others in the given order. LPRT's source there
//     is the light itself rather than the probes nearest it, which may stand beyond a wall or
//     1.5 m over a block the light is 7 m above; no index cell names such a probe. In the open
//     the probes around a light share it (runtime/probe_cache.h, the footprint factor), which
//     measured better there: the lit island at 22:00, local_lights 5.9 % shared against 7.7 %
//     with every lamp on its own source (docs/runtime.md, "Sources where the lights stand").
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {

// A probe whose hits are more than this share back faces is inside geometry. Not one half: from
// inside a block resting on the ground (a rock, a floor slab) the ground's front faces take up to
// half the hits. From outside, back faces show only through cracks and the undersides of open
// meshes: on the default island 0.25 relocates 0.6% of the 63,600 candidates and drops 0.04%.
inline constexpr double kInsideBackfaceFraction = 0.25;
// A covered candidate is enclosed (PlacementSettings::enclosed_*) when at least kEnclosedWalls of
// kEnclosedRays horizontal rays from it (evenly spread in azimuth) meet static geometry within
// kEnclosedRangeM: walls all round, as in a room (a door or window lets one or two out), a
// corridor (two out), a box open on one side (one); not under a deck, an overhang or an arcade,
// whose sides are open (measured: a deck 30 m wide put 60 probes under it with "most of all rays
// meet geometry", since its ground and underside take every ray but the horizontal ones).
inline constexpr int kEnclosedRays = 8;
inline constexpr int kEnclosedWalls = 6;
inline constexpr double kEnclosedRangeM = 12.0;
// PlacementSettings::covered_stack_m: stacked candidates stand at least min_vertical_m plus this
// apart, so that the float sum does not put them a hair under the least distance.
inline constexpr double kStackMarginM = 0.01;

struct PlacementSettings {
  double column_spacing_m = 4.0;      // static pass ray spacing [1, slide 15]
  double vegetation_spacing_m = 8.0;  // vegetation pass ray spacing [1, slide 16]
  double lift_m = 1.5;                // probe height above the surface hit (metres)
  // Minimum distance (cylinder). 8 m / 3 m measured on the default island (worlds/island.json,
  // seed 7): 49 / 64.4 / 79 probes per 64 m sector (min / mean / max), near the talk's ~70
  // (slide 22). On the 4 m column lattice any value in (5.66, 8] keeps every other column on flat
  // ground (64 per sector); the rest come from slopes, stacked floors and vegetation.
  double min_horizontal_m = 8.0;
  double min_vertical_m = 3.0;
  // Under a roof or an overhang (a covered static hit, step 1) the light changes within metres,
  // and those probes are the only ones indoors (issue 16): columns there are cast every
  // `covered_column_spacing_m` as well, and a covered candidate is kept unless an accepted probe
  // lies within `covered_min_horizontal_m` of it (and min_vertical_m). Equal to the open values,
  // the talk's rule.
  double covered_column_spacing_m = 4.0;
  double covered_min_horizontal_m = 8.0;
  // Enclosed spaces under roofs (rooms, storeys, a box open on one side: a covered candidate with
  // walls all round, kEnclosedWalls) change their light
  // within a room's width, and the runtime's fine level blends their probes (visibility.h, issue
  // 35): columns there are cast every `enclosed_column_spacing_m` as well (after every other
  // column), and an enclosed candidate is kept unless an accepted probe lies within
  // `enclosed_min_horizontal_m` of it (and min_vertical_m). No finer than the covered values: the
  // placement of the builds before 2026-12-06.
  double enclosed_column_spacing_m = 2.0;
  double enclosed_min_horizontal_m = 2.0;
  // Under a roof, a space taller than a storey (a hall, an atrium, a stairwell, a gallery's void)
  // gets more than its floor's candidate: one every `covered_stack_m` above the first (at least
  // min_vertical_m apart, kStackMarginM more so that rounding does not reject them), up to
  // lift_m / 2 under its ceiling. Its ceiling then has a probe within the fine level's reach
  // (runtime::FineLookupOptions::radius_m): with one probe per floor, zdm2's 6.5 m halls read
  // their ceilings from the far field, +101 % too bright (2026-12-07). 0 = one probe per floor
  // (the talk's rule, the builds before 2026-12-07's sixth session).
  double covered_stack_m = 3.0;
  // Both enclosed values to `m` metres; 0 = the covered values (the placement before 2026-12-06).
  void setEnclosedSpacing(double m) {
    enclosed_column_spacing_m = m == 0.0 ? covered_column_spacing_m : m;
    enclosed_min_horizontal_m = m == 0.0 ? covered_min_horizontal_m : m;
  }
  // Whether enclosed spaces get denser probes than any covered place (else no enclosure test runs).
  bool enclosedDenser() const {
    return enclosed_column_spacing_m < std::min(covered_column_spacing_m, column_spacing_m) ||
           enclosed_min_horizontal_m < std::min(covered_min_horizontal_m, min_horizontal_m);
  }
  // The least distance from a probe to static geometry, and half the least gap a probe may stand
  // in (issue 16). 0.5 m: a probe that close to a wall sees it over half its sphere. On the
  // default island it drops 163 of its 63,651 candidates (0.26 %), more than the inside test does.
  double clearance_m = 0.25;
  // Step 4: a covered candidate is not moved to within clearance_m of the static surface above its
  // column hit or past it. The bake turns it off without the fine level (BakeSettings::
  // covered_visibility), whose covered flags it clears: those bakes' bytes are the builds' before
  // 2026-12-07.
  bool covered_stays_under = true;
  // Step 5: a covered candidate and an accepted probe (either covered) reject each other only if
  // they see each other: no static surface on the segment between them. A roof's open probe is no
  // longer rejected by the room's probe 2.8 m under it, which left the roof of `living_room`
  // (a building on a sector corner, each quarter of it in its own sector) with no probe of its
  // side and its roof read 89 % too dark (2026-12-07). Off without the fine level, as
  // covered_stays_under.
  bool covered_sight = true;
  // Step 6: a sector over the cap thins its denser probes under roofs first (the covered and the
  // enclosed distances grow towards the open one), and the open lattice, the far field's, only
  // once they reach it. Thinning all alike left the roofs of the 1 km town's centre without an
  // open probe: the cells over them named a storey's probe 18 m away (2026-12-07). false: all
  // alike, the rule before.
  bool thin_near_first = true;
  int inside_test_rays = 32;          // rays of the inside test
  double inside_test_range_m = 16.0;  // their length (bounds the geometry placement depends on)
  uint64_t seed = 1;                  // keys the inside-test directions
};

// An interior volume in the gather's local frame.
struct LocalInterior {
  raytrace::Box box;
  glm::vec3 probe_position{0.f};
  uint16_t index = 0;  // 1-based: World::interiors[index - 1]
};

struct PlacedProbe {
  glm::vec3 position{0.f};  // local frame of the SectorGeometry
  uint16_t flags = 0;       // ProbeFlag bits
  uint16_t interior = 0;    // 0 or 1-based interior index
};

struct PlacementStats {
  size_t static_candidates = 0;      // step 1
  size_t vegetation_candidates = 0;  // step 2
  size_t interior_probes = 0;        // step 3
  size_t relocated = 0;              // step 4: moved out of geometry
  size_t dropped_inside = 0;         // step 4: inside geometry, no offset worked
  size_t dropped_gap = 0;            // steps 1 and 4: in a gap under 2 clearance_m, or nearer a
                                     // surface than clearance_m with no offset clear of it
  size_t rejected_distance = 0;      // step 5
  size_t thinned_cap = 0;            // step 6: removed to respect the 255 cap
  uint64_t rays = 0;                 // rays cast
};

// At most this many light sources per sector (step 7): the brightest lights of a sector keep
// their own source, the rest are shared out over probes as moving lights are (runtime/probe_cache.h).
inline constexpr int kMaxLightSourcesPerSector = 32;

// Places the probes of the sector at `offset` (sector keys relative to geometry.key; (0,0) for
// the geometry's own sector, neighbours for LPRT sources) using `scene` built over `geometry`.
// Positions are in the geometry's local frame. `interiors` empty unless the world asks for them;
// `light_sources` (local frame, inside the sector, at most kMaxLightSourcesPerSector, checked)
// empty unless the bake has LPRT. Thread-safe (reads only). Returns at most 255 probes.
std::vector<PlacedProbe> placeProbes(const raytrace::RayScene& scene, const raytrace::SectorGeometry& geometry, glm::ivec2 offset,
                                     std::span<const LocalInterior> interiors, const PlacementSettings& settings,
                                     PlacementStats& stats, std::span<const glm::vec3> light_sources = {});

}  // namespace drtv::baker
