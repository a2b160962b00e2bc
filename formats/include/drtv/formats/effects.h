// drtv/formats/effects.h — the lighting effects a world asks for (DESIGN.md, "Effects a scene
// calls for"). A stage whose effect is absent is skipped in the bake, the archive and the runtime.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace drtv {

// Bit flags; stored as a uint32 in the archive manifest (values are part of the file format).
enum Effect : uint32_t {
  kEffectSunBounce = 1u << 0,         // PRT: sun light bounced once or more off static geometry
  kEffectSkyBounce = 1u << 1,         // PRT: sky light bounced off static geometry
  kEffectDirectSky = 1u << 2,         // sky visibility per basis: the sky seen directly
  kEffectLocalLights = 1u << 3,       // LPRT: bounce from dynamic point lights (128 sources)
  kEffectInteriors = 1u << 4,         // artist interior volumes with a designated probe
  kEffectDistantOcclusion = 1u << 5,  // top-down occlusion tiles for distant ambient
  kEffectVolumeBlur = 1u << 6,        // blur of the 96x96x16 volume (the talk's PC path)
};
inline constexpr uint32_t kAllEffects = 0x7f;

// Lower-case names, as in world JSON and reports: "sun_bounce", "sky_bounce", "direct_sky",
// "local_lights", "interiors", "distant_occlusion", "volume_blur".
std::string_view effectName(Effect e);

// Parses one name; std::nullopt if unknown.
std::optional<Effect> parseEffect(std::string_view name);

// "sun_bounce, sky_bounce" for a mask; "none" for 0. Thread-safe.
std::string effectsToString(uint32_t mask);

}  // namespace drtv
