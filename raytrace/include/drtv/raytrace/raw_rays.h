// drtv/raytrace/raw_rays.h — raw Embree throughput on the bake's own scenes, so that the bake's
// rays/s can be read against what the ray tracer alone does on the same geometry (`drtv
// bench-bake`, which owns the measurement: the program links no benchmark helper). Embree and
// TBB stay private to raytrace/src.
#pragma once

#include <cstdint>
#include <span>

#include "drtv/raytrace/ray_log.h"
#include "drtv/raytrace/ray_scene.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/error.h"

namespace drtv::raytrace {

struct RawRayFigures {
  uint64_t rays = 0;                   // rays cast per mode
  size_t triangles = 0;                // mean triangles per scene
  double single_rays_per_s = 0;        // rtcIntersect1, one ray at a time, all threads
  double stream_rays_per_s = 0;        // rtcIntersect1M, 256 rays sharing an origin, all threads
  double occluded_stream_rays_per_s = 0;  // rtcOccluded1M, same rays
  // The same per second of this process's CPU time (all threads): robust to other processes
  // competing for the cores, which wall-clock rates are not.
  double single_rays_per_cpu_s = 0, stream_rays_per_cpu_s = 0, occluded_stream_rays_per_cpu_s = 0;
};

// CPU seconds used so far by this process, all threads (CLOCK_PROCESS_CPUTIME_ID).
double processCpuSeconds();

// For each sector in `keys`, gathers it with `halo_m`, builds its scene and casts rays/keys.size()
// incoherent rays (uniform directions from points 1.5 m above the ground, 256 per point) in each
// mode, in parallel over points (TBB). Scene builds are not timed. Errors: Embree's.
Result<RawRayFigures> measureRawRays(const WorldGeometry& geometry, std::span<const SectorKey> keys, uint64_t rays,
                                     double halo_m, uint64_t seed = 1);

// Embree alone on a bake's own rays: `log`'s calls cast again on `scene` through the same entry
// points (rtcIntersect1/1M, rtcOccluded1/1M, the same batches), `repeat` times, in parallel over
// calls (TBB); results are discarded. The scene must be the one the calls were made on.
struct ReplayFigures {
  uint64_t rays = 0;  // rays cast (log rays x repeat)
  double wall_s = 0, cpu_s = 0;
};
ReplayFigures replayRays(const RayScene& scene, const RayLog& log, int repeat = 1);

}  // namespace drtv::raytrace
