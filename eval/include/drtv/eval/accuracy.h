// drtv/baker/accuracy.h — what each approximation of drtv costs in accuracy and what each
// refinement costs in time and memory, measured against the path-traced reference (reference.h)
// on the same world: `drtv accuracy`. DESIGN.md, "Accuracy and its cost".
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012: slides 19-24 (4
//      transfer bases, band-1 SH, 16-bit storage, LPRT with 128 sources), 32 ("more basis
//      directions can be added for better accuracy"), 33-36 (RGBA8 volumes of 96x96x16).
//  [2] McTaggart, "Half-Life 2 / Valve Source Shading", GDC 2004 (the ambient cube: six axis
//      irradiances weighted by the squared normal components).
//  [3] Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
//      SIGGRAPH 2001: irradiance is dominated by bands 0-1; odd bands above 1 vanish under the
//      clamped cosine, so the band-1 SH irradiance E(n) = a + b.n is exactly a = the mean of the
//      six axis irradiances up to band 4, b_i = (E(+e_i) - E(-e_i)) / 2 (no band-3 or 5 error).
//
// Method. The world is baked in memory (bakeInMemory) over a block of sectors (default: the 3 x 3
// block around the centre of its geometry). Sample points: surface points seen from the probes
// (a ray from a probe in a random direction; its first front-face hit and that face's normal) and,
// when the world has them, points on dynamic objects (area-weighted); all keyed by the seed and
// kept inside the block's centre sector(s) so that every point has baked neighbours. For each
// point and hour, the reference ambient (sun bounce + sky bounce + direct sky + local lights) is
// path-traced once; every configuration's ambient at the same points is compared with it:
//   rel_error = sum over points, hours, channels |E - E_ref| / max(sum E_ref, N kAmbientErrorFloor)
//   bias      = sum (E - E_ref) / (the same denominator)
//   abs_error = sum |E - E_ref| / N       (mean absolute error per point, hour and channel)
// with N the number of terms. The floor keeps a (nearly) black reference, e.g. a sun-only scene
// with nothing to bounce from, from dividing by ~0: errors are then relative to the floor and the
// row's note says so; abs_error is the figure to read there.
// and the reference's own noise floor, sum of standard errors / sum E_ref, is reported beside.
// Knobs, one at a time around the default (BakeSettings::forQuality(kDefault), the runtime's
// defaults: nearest fill, 2 x 2 x 4 m texels, RGBA8):
//   rays_per_basis   32 64 [128] 256 512      bake (bake time changes)
//   bounces          1 [2] 3 4                bake
//   basis            [4-basis] ambient-cube sh-l1: the probe's directional representation alone.
//                    These rows take the probe values from the reference (path-traced irradiance
//                    at the probe for the 4 bases, or the 6 axes), look up the probe the index
//                    grid names at the normal-offset point (no trilinear), so the representation
//                    is the only difference between them [1, slide 32; 2; 3].
//   fill             [nearest] smooth         runtime
//   texel_m          1 [2] 4 (horizontal; vertical is twice)  runtime
//   storage          [8-bit] 16-bit float: the volume texels' precision. Emulated outside the
//                    runtime (nearest fill, no blur: trilinear over texels each holding its index
//                    cell's probe colours, quantised with the runtime's HDR scale); the 8-bit
//                    emulation's difference from the runtime is reported as a check.
//   part             the default configuration one relighting term at a time (sun bounce, sky
//                    bounce, direct sky, local lights) against the reference's same part; errors
//                    as a share of the whole reference ambient, so the biases add up.
//   sun_window       [hanning] lanczos none: the band-1 window on the sun's SH (lighting_sh.h).
//   lprt_sources     8 32 64 [128]            LPRT rows (only for worlds with point lights): the
//                    bake's sources are sorted nearest first, so keeping the first S of them is
//                    what a bake with S sources gives.
// Costs per row: bake_s (in-memory bake wall seconds; rows that reuse the default bake repeat its
// time), relight_fill_ms (median of Runtime::update after a time-of-day change: relight every
// resident probe, repack, refill all three volumes), probe_bytes (encoded sector bytes of the
// block), volume_bytes (the three textures at the row's precision and texel count).
//
// Determinism: sample points, the reference and the bakes are keyed by the seed; the errors do
// not depend on threads. Times do (they are measurements).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "drtv/baker/bake.h"
#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {

struct AccuracyOptions {
  std::vector<double> hours{9.0, 16.0};  // times of day evaluated (errors sum over them)
  int points = 240;                      // surface sample points (>= 1)
  int reference_samples = 512;           // reference paths per point and hour (>= 2)
  int probe_samples = 256;               // reference paths per probe direction (basis rows)
  std::optional<raytrace::SectorRange> sectors;    // bake block; default: 3 x 3 around the geometry's centre
  uint64_t seed = 1;
  int threads = 0;                       // 0 = all hardware threads
  int timing_repeats = 5;                // relight + fill timings per row (median)
  // Stratified points: each surface category found (open ground, walls, enclosed) gets an equal
  // share of the static points, so that the hard places are measured with as many points as the
  // open ground (issue 16); the totals then weigh the categories equally, not by area.
  bool stratify = false;
  // The "technique" rows: these registered techniques (technique.h); empty = every one.
  std::vector<std::string> techniques;
  // Techniques whose own knob rows (TechniqueInfo::knobs, one knob at a time around the
  // technique's defaults) are added after DRTV's, which are always there: "lpv" (minutes per row on
  // the island: each re-renders its RSMs at every camera move), "sweep", "ambient-cube" (seconds
  // each). `drtv accuracy --knobs <name>,...`.
  std::vector<std::string> knobs;
  // Progress lines ("bake rays_per_basis=32 ...") for a terminal; may be empty.
  std::function<void(const std::string&)> progress;
};

// Irradiance per channel below which a reference ambient counts as black for relative errors, in
// the world's linear RGB units (the tropical noon sun is 3.0, its bounce off grass ~0.3): a
// thousandth of a lit surface's ambient, and about the smallest step an 8-bit volume texel can
// show at the runtime's HDR scale, so an error under it is invisible anyway.
inline constexpr double kAmbientErrorFloor = 1e-3;

// Errors of `values` against `reference` (same size), as defined in the header.
struct AmbientError {
  double rel = 0;        // relative L1 error, RGB, denominator floored
  double bias = 0;       // signed relative error, same denominator
  double abs = 0;        // mean absolute error per value and channel (irradiance units)
  bool floored = false;  // the reference's sum was under the floor: rel and bias are relative to it
};
AmbientError ambientError(const std::vector<glm::vec3>& values, const std::vector<glm::vec3>& reference);

// Where a sample point lies (issue 16: the hard places measured apart from the open ground). In
// order of precedence: on a dynamic object; enclosed (indoors or under a roof: under 30 % of the
// cosine-weighted upper hemisphere above it is open sky); on or within 2 m of a wall or facade (its
// normal within 60 deg of horizontal, or a horizontal ray from just above it meets such a surface
// within 2 m); else open ground. Vegetation counts as geometry (the reference scene does not tell
// canopy apart).
enum SurfaceCategory : int { kOpenGround = 0, kWallOrFacade, kEnclosed, kOnDynamic, kSurfaceCategoryCount };
const char* surfaceCategoryName(SurfaceCategory c);  // "open", "wall", "enclosed", "dynamic"

// A row's error over the points of one category, as the row's own (whole ambient, or one term as a
// share of the category's whole reference ambient).
struct CategoryError {
  size_t points = 0;     // sample points in the category (each at every hour)
  double rel = 0, bias = 0, abs = 0;
  bool floored = false;
};

struct AccuracyRow {
  std::string knob;         // "rays_per_basis", "bounces", "part", "sun_window", "basis", "fill", "texel_m",
                            // "storage", "lprt_sources", "sources_per_light", "light_sources",
                            // "technique" (value: a registered technique's name)
  std::string value;        // "128", "ambient-cube", ...
  bool is_default = false;  // the talk's / drtv's default setting of this knob
  double rel_error = 0;     // relative L1 error, RGB (see the header)
  double bias = 0;          // signed relative error
  double bake_s = 0;        // wall seconds of the bake this row uses
  double relight_fill_ms = 0;  // median wall milliseconds of relight + full fill
  size_t probe_bytes = 0;   // encoded sectors of the block
  size_t volume_bytes = 0;  // the three volume textures
  std::string note;         // what is special about the row
  double abs_error = 0;     // mean absolute error per point, hour and channel (see the header)
  std::array<CategoryError, kSurfaceCategoryCount> categories{};  // the same error by category
  std::string by_category = {};  // its name in the report's table by category, "" if not there (KnobRow)
};

// One sample point at one hour, as the default DRTV row shaded it beside the reference
// (accuracy-points.csv): to find where a category's error comes from.
struct AccuracyPoint {
  glm::dvec3 position{0.0};
  glm::vec3 normal{0.f};
  SurfaceCategory category = kOpenGround;
  double hour = 0;
  glm::vec3 reference{0.f};  // the path tracer's ambient
  glm::vec3 drtv{0.f};       // the default DRTV row's
};

struct AccuracyReport {
  std::string world;                  // name or file
  raytrace::SectorRange sectors;                // the block baked
  size_t points = 0, dynamic_points = 0;
  std::array<size_t, kSurfaceCategoryCount> category_points{};  // sample points per SurfaceCategory
  bool stratified = false;            // AccuracyOptions::stratify
  std::vector<double> hours;
  int reference_samples = 0;
  double reference_s = 0;             // wall seconds of the reference at the points
  double reference_noise = 0;         // sum of standard errors / sum of the reference (RGB)
  glm::dvec3 reference_mean{0.0};     // mean reference ambient (RGB)
  double emulation_check = 0;         // relative L1 difference, emulated 8-bit vs the runtime
  std::vector<AccuracyRow> rows;
  std::vector<AccuracyPoint> point_values;  // every (hour, point) of the default DRTV row
  std::vector<std::string> skipped;   // "lprt_sources: the world has no point lights"
  std::vector<std::string> notes;
  double wall_s = 0;
};

// Runs the sweep (see the header). `where` prefixes errors. Errors: bake errors, a block with no
// probes, no sample point found, bad options (no hours, points < 1, samples < 2).
Result<AccuracyReport> measureAccuracy(const worlds::World& world, const std::string& where, const AccuracyOptions& options);

// Checks AccuracyOptions::knobs: each a registered technique that declares knob rows. Errors name
// the one that is not and list those that are.
Result<void> checkKnobs(const std::vector<std::string>& names);

// Writes accuracy.csv, accuracy.json, accuracy.md (the tables), accuracy.png (relative error
// against bake time, relight + fill time and memory) and accuracy-points.csv (AccuracyPoint per
// line) into `dir` (created if needed).
Result<void> writeAccuracyReport(const AccuracyReport& report, const std::filesystem::path& dir);

}  // namespace drtv::eval
