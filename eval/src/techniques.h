// The built-in techniques' registrations, one function per folder under eval/techniques/
// (technique.cpp calls each once, on first use of the registry), and what several of them share.
#pragma once

#include <array>
#include <cstdint>
#include <utility>

#include "drtv/eval/technique.h"
#include "drtv/runtime/runtime.h"

namespace drtv::eval {

// eval/techniques/drtv: Deferred Radiance Transfer Volumes (the talk's), nearest and smooth fills.
Result<void> registerDrtvTechniques();
// eval/techniques/probe_reference: DRTV's probes with path-traced values, no volume (basis rows).
Result<void> registerProbeReferenceTechnique();
// eval/techniques/ambient_cube: DRTV's probes with a six-axis ambient cube, baked, relit, a volume (in memory).
Result<void> registerAmbientCubeTechnique();
// eval/techniques/lpv: cascaded light propagation volumes over ray-cast RSMs (drtv/lpv/lpv.h).
Result<void> registerLpvTechnique();
// eval/techniques/sweep: the top-down sweep light grid (seed 001), no bake.
Result<void> registerSweepTechniques();

// The runtime's relighting terms by the names of the reference's parts (the `part` parameter and
// rows), in the reference's order (reference::ReferencePart).
inline constexpr std::array<std::pair<const char*, uint32_t>, 4> kRuntimeParts = {
    std::pair{"sun_bounce", uint32_t(runtime::kComponentSunBounce)}, std::pair{"sky_bounce", uint32_t(runtime::kComponentSkyBounce)},
    std::pair{"direct_sky", uint32_t(runtime::kComponentDirectSky)}, std::pair{"local_lights", uint32_t(runtime::kComponentLocalLights)}};

// The `part` parameter of the techniques on drtv's runtime terms: all (nothing) or one component.
inline void readPart(ParamReader& r, std::optional<uint32_t>& part) {
  std::optional<uint32_t> none;
  r.oneOf(std::string("part"), part,
          {{"all", none}, {"sun_bounce", std::optional<uint32_t>(runtime::kComponentSunBounce)},
           {"sky_bounce", std::optional<uint32_t>(runtime::kComponentSkyBounce)},
           {"direct_sky", std::optional<uint32_t>(runtime::kComponentDirectSky)},
           {"local_lights", std::optional<uint32_t>(runtime::kComponentLocalLights)}});
}

}  // namespace drtv::eval
