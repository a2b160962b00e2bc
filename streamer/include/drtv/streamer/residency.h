// drtv/streamer/residency.h — which sectors should be in memory for a camera: the volume's
// footprint first, then the nearest sectors along the direction of travel.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slide 24: "a maximum
//      of 51 sectors around the player loaded in memory at any one time".
//  [2] ibid., slides 34-36: the 96x96x16 volume follows the camera and scrolls toroidally; its
//      texels are filled from the probes of the sectors it covers.
//
// Ranking (pure, deterministic, no allocation once `out` has capacity). A sector's time of need is
// when the footprint, moving at the camera's velocity, first overlaps it (0: it does now):
//   tier 0  sectors needed within `guard_s` seconds: a sector missing when needed is a visible
//           miss. The footprint is swept, not sampled at its two ends: a camera moving diagonally
//           sweeps corners that neither the footprint now nor the one guard_s ahead covers, and
//           those sectors were the misses of fast flights (the 16 km² island at 300 m/s: 325
//           sector-frames before, deterministic I/O). Ordered by time of need (metres of travel).
//   tier 1  every other sector within `candidate_radius_m` of the look-ahead segment
//           [camera, camera + velocity * lookahead_s], nearest first.
// With Camera::path_ahead the sweep and the look-ahead follow those points (the camera, then each
// point at its time; beyond the last, its last step's direction) instead of the velocity.
// Sectors already held rank `hysteresis_m` nearer than they are (so that a sector at the edge
// of the set is not dropped and reloaded every frame); ties go by time of need, distance to the
// look-ahead segment, then key. Only
// sectors the archive holds are ranked: sea and the world's outside have no sector and are never
// misses. The streamer lengthens guard_s to cover the load latency it measures (streamer.h).
//
// Conventions: world metres, Z up; only x and y matter here (sectors span all heights).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/probe_cache.h"
#include "drtv/runtime/volume.h"

namespace drtv::streamer {

// The talk's residency limit [1], the runtime's one definition (its cache has that many slots).
using runtime::kMaxResidentSectors;

// What the streamer needs to know about the viewer.
struct Camera {
  Camera() = default;
  Camera(const glm::dvec3& position, const glm::dvec3& velocity = glm::dvec3(0.0)) : position_m(position), velocity_mps(velocity) {}
  glm::dvec3 position_m{0.0};    // world metres
  glm::dvec3 velocity_mps{0.0};  // world metres per second (the look-ahead direction and reach)
  // Where the camera will be, when the engine knows (a spline it follows, a vehicle's route, a
  // cutscene): path_ahead[i] is its position path_step_s * (i + 1) seconds from now. Given, the
  // look-ahead follows these points instead of the straight line along the velocity, so that a
  // turn's sectors are asked for before the camera turns. Not owned: valid during the call that
  // takes the camera. Empty (or path_step_s <= 0) = the velocity alone. The ranking follows at
  // most 126 points, as far as max(guard, look-ahead) reaches, and goes straight on past the last
  // along its step; each costs it a test per sector, so a handful is best (drtv fly gives 8).
  std::span<const glm::dvec3> path_ahead;
  double path_step_s = 0.0;
  // How far the camera may stray from the straight lines between those points (a curve's chord
  // error, metres): the sweep's footprint is grown by it, so that a curve's bulge between two
  // points is not missed.
  double path_tolerance_m = 0.0;
};

struct ResidencyOptions {
  int max_sectors = kMaxResidentSectors;  // sectors resident or in flight, at most [1]
  // The runtime's volume [2], whose horizontal footprint about the camera (size x texel size:
  // 96 x 2 m = a 192 m square by default) is tier 0. Pass the runtime's own options here.
  runtime::VolumeOptions volume;
  // Sectors the moving footprint reaches within guard_s are tier 0: loads take a few frames and
  // the footprint must be complete when the camera gets there. 0.5 s at 100 m/s is 50 m, more than
  // the simulated I/O latency (2 frames) and a thread pool's queueing under a sector-row crossing.
  // The least: the streamer raises it to cover the latency it measures (StreamerOptions).
  double guard_s = 0.5;
  // Remaining slots go to sectors nearest the segment camera -> camera + velocity * lookahead_s.
  double lookahead_s = 2.0;
  // Held sectors rank this much nearer than they are (metres): a quarter sector, enough to stop
  // a sector at the boundary from flapping as the camera weaves.
  double hysteresis_m = 16.0;
  // Sectors farther than this from the look-ahead segment are never candidates, metres. 6
  // sectors: more than the radius of 51 sectors packed in a disc (~4 sectors).
  double candidate_radius_m = 384.0;
};

// The volume's horizontal footprint about a position: [min, max) in world metres.
struct Footprint {
  glm::dvec2 min{0.0}, max{0.0};
};
Footprint volumeFootprint(const glm::dvec3& position_m, const ResidencyOptions& options);
// True when sector `key`'s 64 m square overlaps the open footprint (touching edges do not count).
bool overlaps(SectorKey key, const Footprint& footprint);

// One ranked candidate.
struct RankedSector {
  SectorKey key;
  int tier = 1;                       // 0 = inside (or about to be inside) the volume's footprint
  double distance_m = 0.0;            // to the look-ahead segment, before hysteresis
  double score_m = 0.0;               // the sort key (see rankSectors), less hysteresis_m when held
  // Camera seconds until the volume's footprint, moving at the camera's velocity, first overlaps
  // the sector (0: it does now); infinity when it does not within max(guard_s, lookahead_s).
  double need_s = 0.0;
  const SectorEntry* entry = nullptr; // in the manifest passed to rankSectors
};

// Ranks the manifest's sectors for `camera` (see the top of this file) into `out` (cleared
// first), best first. `held` is sorted: keys already resident or in flight, which get the
// hysteresis bonus. Thread-safe (pure); allocates only when `out` must grow.
void rankSectors(const Manifest& manifest, const Camera& camera, const ResidencyOptions& options,
                 std::span<const SectorKey> held, std::vector<RankedSector>& out);

// Keys of the manifest's sectors that overlap the volume's footprint about `position_m`, sorted,
// appended to `out` (cleared first). These are the sectors whose absence is a miss.
void footprintSectors(const Manifest& manifest, const glm::dvec3& position_m, const ResidencyOptions& options,
                      std::vector<SectorKey>& out);

// The 7 x 7 block of sectors centred on the sector under `position_m` (x and y): 49 sectors,
// within the 51 a streamer keeps resident (DESIGN.md). What the tools that hold sectors as a
// streamer would, without streaming, load about a camera (drtv query, drtv render). Total: the
// block is clamped to the key range.
inline constexpr int32_t kResidentBlockRadius = 3;
SectorRange residentBlock(const glm::dvec3& position_m);

// Horizontal distance from sector `key`'s square to the segment [a, b] (x and y only), metres;
// 0 when they touch. Pure.
double distanceToSegment(SectorKey key, const glm::dvec2& a, const glm::dvec2& b);

}  // namespace drtv::streamer
