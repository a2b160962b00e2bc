// render_support.h — private helpers shared by render.cpp, accuracy.cpp and vdb.cpp: a runtime
// set up from baked sectors the way an engine would, and small image helpers.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/runtime.h"

namespace drtv::eval::detail {

// Runtime options an engine would pick for an archive with `effects` baked
// (runtime::optionsForEffects), with the fill mode asked for.
inline runtime::RuntimeOptions runtimeOptionsFor(uint32_t effects, bool smooth_fill) {
  runtime::RuntimeOptions o = runtime::optionsForEffects(effects);
  o.volume.fill = smooth_fill ? runtime::FillMode::kSmooth : runtime::FillMode::kNearest;
  return o;
}

// Whether `key` is in the 7 x 7 block of sectors around world (x, y): what a streamer holds
// (49 <= the 51 resident sectors of DESIGN.md), the same block `drtv query` loads.
inline bool inStreamingBlock(SectorKey key, const glm::dvec3& at) {
  const SectorKey c = sectorAt(at.x, at.y);
  return std::abs(int64_t(key.ix) - c.ix) <= 3 && std::abs(int64_t(key.iy) - c.iy) <= 3;
}

// A runtime lit by `baked`'s sky, lights and interiors at `hour`, holding the sectors for which
// `keep(key)` is true (at most options.cache.max_sectors), updated at `camera`. `loaded` receives
// the count. Errors: unsound lighting, a non-finite hour, a sector the cache rejects.
template <class Keep>
Result<std::unique_ptr<runtime::Runtime>> makeRuntime(const Manifest& baked, std::span<const Sector> sectors, double hour,
                                                      const runtime::RuntimeOptions& options, const glm::dvec3& camera,
                                                      Keep keep, size_t* loaded) {
  auto made = runtime::runtimeForArchive(baked, options, hour);
  if (!made) return std::unexpected(made.error());
  std::unique_ptr<runtime::Runtime> rt = std::move(*made);
  size_t n = 0;
  for (const Sector& s : sectors) {
    if (!keep(s.key)) continue;
    if (int(n) >= options.cache.max_sectors) break;
    if (auto r = rt->addSector(s); !r) return std::unexpected(r.error().context("sector " + toString(s.key)));
    ++n;
  }
  rt->update(camera);
  if (loaded) *loaded = n;
  return rt;
}

// Rec. 709 luminance of linear RGB.
inline double luminance(const glm::vec3& c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

}  // namespace drtv::eval::detail
