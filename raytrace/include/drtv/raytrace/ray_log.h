// drtv/raytrace/ray_log.h — a benchmark's hook, not for production: records every ray query made
// on any RayScene while installed. `drtv bench-bake` bakes a few sectors with one installed and
// then casts exactly those rays again with nothing else around them (drtv/raytrace/raw_rays.h), to
// time Embree alone on the bake's own rays. Kept out of ray_scene.h: a bake never includes it.
#pragma once

#include <cstdint>
#include <mutex>
#include <vector>

#include "drtv/raytrace/ray_scene.h"

namespace drtv::raytrace {

// Every query made while a log is installed (setRayLog), in call order per thread.
struct RayLog {
  enum class Kind : uint8_t { kIntersect1, kIntersectM, kOccluded1, kOccludedM };
  struct Call {
    Kind kind;
    uint32_t first, count;  // rays[first, first + count)
  };
  std::mutex mutex;
  std::vector<Call> calls;
  std::vector<Ray> rays;
};
// Installs `log` process-wide (nullptr: none, the default). Not for production bakes: every
// query then takes the log's mutex. When none is installed a query pays one relaxed load.
void setRayLog(RayLog* log);

}  // namespace drtv::raytrace
