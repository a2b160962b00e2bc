#include "drtv/formats/effects.h"

#include <array>
#include <utility>

namespace drtv {
namespace {
constexpr std::array<std::pair<Effect, std::string_view>, 7> kNames{{
    {kEffectSunBounce, "sun_bounce"},
    {kEffectSkyBounce, "sky_bounce"},
    {kEffectDirectSky, "direct_sky"},
    {kEffectLocalLights, "local_lights"},
    {kEffectInteriors, "interiors"},
    {kEffectDistantOcclusion, "distant_occlusion"},
    {kEffectVolumeBlur, "volume_blur"},
}};
}  // namespace

std::string_view effectName(Effect e) {
  for (const auto& [effect, name] : kNames)
    if (effect == e) return name;
  return "unknown";
}

std::optional<Effect> parseEffect(std::string_view name) {
  for (const auto& [effect, n] : kNames)
    if (n == name) return effect;
  return std::nullopt;
}

std::string effectsToString(uint32_t mask) {
  std::string out;
  for (const auto& [effect, name] : kNames) {
    if (!(mask & effect)) continue;
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out.empty() ? "none" : out;
}

}  // namespace drtv
