// The bake's settings: the quality presets (bake.h, BakeSettings), their check, the description a
// manifest stores, and the effects a world asks the bake for.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "drtv/baker/bake.h"

namespace drtv::baker {
namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

Result<void> validateSettings(const BakeSettings& s) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  const PlacementSettings& p = s.placement;
  if (!in(p.column_spacing_m, 1.0 / 16, 64.0)) return fail("column_spacing_m must be in [1/16, 64] m");
  if (!in(p.vegetation_spacing_m, 1.0 / 16, 64.0)) return fail("vegetation_spacing_m must be in [1/16, 64] m");
  if (!in(p.lift_m, 0.0, 64.0)) return fail("lift_m must be in [0, 64] m");
  if (!in(p.min_horizontal_m, 0.0, 64.0) || !in(p.min_vertical_m, 0.0, 1e4)) return fail("minimum probe distances must be finite and >= 0");
  if (!in(p.covered_column_spacing_m, 1.0 / 16, 64.0)) return fail("covered_column_spacing_m must be in [1/16, 64] m");
  if (!in(p.covered_min_horizontal_m, 0.0, 64.0)) return fail("covered_min_horizontal_m must be finite and in [0, 64] m");
  if (!in(p.enclosed_column_spacing_m, 1.0 / 16, 64.0)) return fail("enclosed_column_spacing_m must be in [1/16, 64] m");
  if (!in(p.enclosed_min_horizontal_m, 0.0, 64.0)) return fail("enclosed_min_horizontal_m must be finite and in [0, 64] m");
  if (!(p.covered_stack_m == 0.0 || in(p.covered_stack_m, 1.0 / 16, 64.0))) return fail("covered_stack_m must be 0 (off) or in [1/16, 64] m");
  if (p.inside_test_rays < 0 || p.inside_test_rays > (1 << 16)) return fail("inside_test_rays must be in [0, 65536]");
  if (!in(p.inside_test_range_m, 0.0, 64.0)) return fail("inside_test_range_m must be in [0, 64] m");
  // A clearance above the lift would refuse flat ground itself.
  if (!in(p.clearance_m, 0.0, std::min(p.lift_m, p.inside_test_range_m))) return fail("clearance_m must be in [0, min(lift_m, inside_test_range_m)]");
  const TransferSettings& t = s.transfer;
  if (t.probe_rays_per_basis < 1 || t.probe_rays_per_basis > (1 << 16)) return fail("probe_rays_per_basis must be in [1, 65536]");
  if (t.surfel_rays < 1 || t.surfel_rays > (1 << 16)) return fail("surfel_rays must be in [1, 65536]");
  if (!in(t.surfel_cell_m, 0.25, 64.0)) return fail("surfel_cell_m must be in [0.25, 64] m (cell keys assume >= 0.25 m)");
  if (t.bounces < 1 || t.bounces > 64) return fail("bounces must be in [1, 64]");
  if (t.sweeps < 0 || t.sweeps > 256) return fail("sweeps must be in [0, 256] (0: bounces - 1)");
  if (t.lprt_sweeps < 0 || t.lprt_sweeps > 256) return fail("lprt_sweeps must be in [0, 256] (0: bounces - 1)");
  if (t.sun_samples != 0 && (t.sun_samples < 2 || t.sun_samples > kMaxSunSamples)) return fail("sun_samples must be 0 or in [2, 8]");
  if (s.grid.visibility_candidates < 1 || s.grid.visibility_candidates > 255) return fail("visibility_candidates must be in [1, 255]");
  if (!in(s.halo_m, 0.0, 1024.0) || !in(s.lprt_halo_m, 0.0, 1024.0)) return fail("halos must be in [0, 1024] m");
  if (auto ok = validateRoomSettings(s.rooms); !ok) return ok;
  if (s.rooms.enabled && s.rooms.max_extent_m > std::min(s.halo_m, s.lprt_halo_m))
    return fail("rooms: max_extent_m must not exceed the halos (the room search gathers that far)");
  return {};
}
const char* qualityName(Quality q) {
  switch (q) {
    case Quality::kDraft: return "draft";
    case Quality::kDefault: return "default";
    case Quality::kHigh: return "high";
  }
  return "?";
}

std::optional<Quality> parseQuality(std::string_view name) {
  if (name == "draft") return Quality::kDraft;
  if (name == "default") return Quality::kDefault;
  if (name == "high") return Quality::kHigh;
  return std::nullopt;
}

BakeSettings BakeSettings::forQuality(Quality q, uint64_t seed) {
  BakeSettings s;
  s.quality = q;
  s.placement.seed = seed;
  s.transfer.seed = seed;
  s.transfer.sweeps = kPresetSweeps;
  switch (q) {
    case Quality::kDraft:
      s.transfer.probe_rays_per_basis = 32;
      s.transfer.surfel_rays = 12;
      s.transfer.surfel_cell_m = 3.f;
      s.transfer.bounces = 2;
      s.grid.visibility_candidates = 4;
      break;
    case Quality::kDefault:
      s.transfer.probe_rays_per_basis = 128;
      s.transfer.surfel_rays = 24;
      s.transfer.surfel_cell_m = 2.f;
      s.transfer.bounces = 2;
      s.grid.visibility_candidates = 8;
      break;
    case Quality::kHigh:
      s.transfer.probe_rays_per_basis = 512;
      s.transfer.surfel_rays = 64;
      s.transfer.surfel_cell_m = 1.f;
      s.transfer.bounces = 3;
      s.grid.visibility_candidates = 16;
      break;
  }
  return s;
}

std::vector<std::pair<std::string, std::string>> BakeSettings::describe() const {
  std::vector<std::pair<std::string, std::string>> d = {
      {"quality", qualityName(quality)},
      {"seed", std::to_string(transfer.seed)},
      {"probe_rays_per_basis", std::to_string(transfer.probe_rays_per_basis)},
      {"surfel_rays", std::to_string(transfer.surfel_rays)},
      {"surfel_cell_m", fmt(transfer.surfel_cell_m)},
      {"bounces", std::to_string(transfer.bounces)},
      {"column_spacing_m", fmt(placement.column_spacing_m)},
      {"vegetation_spacing_m", fmt(placement.vegetation_spacing_m)},
      {"lift_m", fmt(placement.lift_m)},
      {"min_horizontal_m", fmt(placement.min_horizontal_m)},
      {"min_vertical_m", fmt(placement.min_vertical_m)},
      {"inside_test_rays", std::to_string(placement.inside_test_rays)},
      {"grid_visibility_candidates", std::to_string(grid.visibility_candidates)},
      {"grid_search_beyond", grid.search_beyond ? "1" : "0"},
      {"halo_m", fmt(halo_m)},
      {"lprt_halo_m", fmt(lprt_halo_m)},
      {"zstd_level", std::to_string(zstd_level)},
  };
  // Only when not the talk's: a kFc3 bake with the talk's placement (clearance 0) describes
  // itself (and hashes, and packs) as before.
  if (placement.clearance_m != 0.0) d.emplace_back("clearance_m", fmt(placement.clearance_m));
  if (grid.inside_from_neighbours) d.emplace_back("grid_inside_from_neighbours", "1");
  // Only with covered probes to tell apart (the fine level's visibility maps): without them the
  // rule names what the builds before named.
  if (grid.same_side && covered_visibility) d.emplace_back("grid_same_side", "1");
  if (transfer.cell_sides && transfer.representation == Representation::kShL1) d.emplace_back("cache_cell_sides", "1");
  // Only when denser under roofs than in the open (issue 16): other bakes describe themselves as before.
  if (placement.covered_column_spacing_m < placement.column_spacing_m)
    d.emplace_back("covered_column_spacing_m", fmt(placement.covered_column_spacing_m));
  if (placement.covered_min_horizontal_m < placement.min_horizontal_m)
    d.emplace_back("covered_min_horizontal_m", fmt(placement.covered_min_horizontal_m));
  // Only when denser in enclosed spaces than under roofs (issue 35): other bakes as before.
  if (placement.enclosed_column_spacing_m < std::min(placement.covered_column_spacing_m, placement.column_spacing_m))
    d.emplace_back("enclosed_column_spacing_m", fmt(placement.enclosed_column_spacing_m));
  if (placement.enclosed_min_horizontal_m < std::min(placement.covered_min_horizontal_m, placement.min_horizontal_m))
    d.emplace_back("enclosed_min_horizontal_m", fmt(placement.enclosed_min_horizontal_m));
  if (transfer.sweeps != 0) d.emplace_back("sweeps", std::to_string(transfer.sweeps));
  if (transfer.lprt_sweeps != 0) d.emplace_back("lprt_sweeps", std::to_string(transfer.lprt_sweeps));
  // Only when on: a bake without visibility maps describes itself (and hashes, and packs) as before.
  if (covered_visibility) d.emplace_back("covered_visibility", "1");
  // Only when not the 4,096 of the builds before (their archives describe themselves as before).
  if (covered_visibility && visibility_rays != 4096) d.emplace_back("visibility_rays", std::to_string(visibility_rays));
  // Only with the fine level, and only when on (2026-12-07): other bakes describe themselves as before.
  if (covered_visibility && visibility_openings) d.emplace_back("visibility_openings", "1");
  if (covered_visibility && placement.covered_stays_under) d.emplace_back("covered_stays_under", "1");
  if (covered_visibility && placement.covered_sight) d.emplace_back("covered_sight", "1");
  if (covered_visibility && placement.thin_near_first) d.emplace_back("thin_near_first", "1");
  if (covered_visibility && placement.covered_stack_m > 0.0) d.emplace_back("covered_stack_m", fmt(placement.covered_stack_m));
  // Only when on: a bake without them describes itself (and hashes, and packs) as before. Also a
  // bake without LPRT, whose bytes the setting does not change.
  if (light_sources) d.emplace_back("light_sources", "1");
  // Only when off: a bake that finds no room describes itself (and hashes, and packs) as before.
  if (!rooms.enabled) d.emplace_back("rooms", "off");
  if (transfer.representation != Representation::kFc3) d.emplace_back("representation", representationName(transfer.representation));
  if (transfer.representation == Representation::kShL1) d.emplace_back("sun_samples", std::to_string(transfer.sun_samples));
  return d;
}

uint32_t effectsToBake(const worlds::World& world, std::vector<std::string>* skipped) {
  uint32_t e = world.effects & kAllEffects;
  auto skip = [&](Effect effect, const std::string& why) {
    if (!(e & effect)) return;
    e &= ~uint32_t(effect);
    if (skipped) skipped->push_back(std::string(effectName(effect)) + ": " + why);
  };
  if (world.lights.empty()) skip(kEffectLocalLights, "the world has no point lights");
  if (world.interiors.empty()) skip(kEffectInteriors, "the world has no interior volumes");
  if (skipped)
    for (uint32_t bit = 1; bit <= kEffectVolumeBlur; bit <<= 1)
      if (!(world.effects & bit)) skipped->push_back(std::string(effectName(Effect(bit))) + ": not asked for by the world");
  return e;
}

}  // namespace drtv::baker
