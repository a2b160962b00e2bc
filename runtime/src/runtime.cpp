// runtime.cpp — see runtime.h for the reference [1] and what is recomputed when.
#include "drtv/runtime/runtime.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace drtv::runtime {
namespace {
// The HDR scale never drops below this, so that an all-black world packs without dividing by 0.
constexpr float kMinHdrScale = 1e-6f;
// A relight of the sectors that moved lights reach keeps the packed HDR scale while the scale a
// full relight would choose is at least this fraction of it: at worst one bit of the 8 is spent on
// a bright light that moved away. Below it (or when a relit sector exceeds the scale) everything is
// repacked and refilled, as after a full relight.
constexpr float kMinScaleKept = 0.5f;
}  // namespace

glm::vec3 ambientNormal(const glm::vec3& n) {
  const glm::dvec3 d(n);
  const double len = std::sqrt(glm::dot(d, d));
  if (!(len > 1e-30) || !std::isfinite(len)) {
    // A huge finite normal overflows the squared length: rescale by the largest component first.
    const double m = std::max({std::fabs(d.x), std::fabs(d.y), std::fabs(d.z)});
    if (!(m > 0.0) || !std::isfinite(m)) return {0.f, 0.f, 1.f};
    return glm::vec3(glm::normalize(d / m));
  }
  return glm::vec3(d / len);
}

uint32_t componentsFromEffects(uint32_t effects) {
  uint32_t c = 0;
  if (effects & kEffectSunBounce) c |= kComponentSunBounce;
  if (effects & kEffectSkyBounce) c |= kComponentSkyBounce;
  if (effects & kEffectDirectSky) c |= kComponentDirectSky;
  if (effects & kEffectLocalLights) c |= kComponentLocalLights;
  return c;
}

RuntimeOptions optionsForEffects(uint32_t effects) {
  RuntimeOptions o;
  o.components = componentsFromEffects(effects);
  o.effects = effects;
  o.volume.blur = (effects & kEffectVolumeBlur) != 0;
  return o;
}

namespace {
RuntimeOptions withRepresentation(RuntimeOptions o) {
  o.cache.representation = o.representation;
  o.volume.representation = o.representation;
  if (o.sun_band1_window == kSunLobeOfRepresentation) {
    const bool linear = o.representation == Representation::kShL1;
    o.sun_band1_window = linear ? kLinearSunBand1 : kHanningBand1;
    o.sun_band0_scale = linear ? 0.f : 1.f;
  }
  return o;
}
}  // namespace

Runtime::Runtime(RuntimeOptions options)
    : options_(withRepresentation(options)), cache_(options_.cache), volume_(options_.volume, options_.volume_rebuild_updates) {
  current_ = applied_ = evaluateSky(sky_, hour_, options_.sun_band1_window, options_.sun_band0_scale);
}

namespace {
// A point this far outside an interior's box still counts as on its face: the room's surfaces lie
// on an artist's box (island.cpp makes it the room's inside), within float noise; thinner than
// any wall (0.1 m in tests/reference/data/room.json).
constexpr double kInteriorSurfaceSlackM = 0.05;
}  // namespace

const std::vector<uint32_t>* Runtime::interiorsOver(SectorKey key) const {
  const auto it = interiors_by_sector_.find(packKey(key));
  return it == interiors_by_sector_.end() ? nullptr : &it->second;
}

Result<void> Runtime::setLighting(const Sky& sky, std::vector<PointLight> lights, std::vector<InteriorVolume> interiors) {
  if (auto e = validateLighting(sky, lights, interiors); !e) return std::unexpected(e.error().context("lighting"));
  sky_ = sky;
  lights_ = std::move(lights);
  interiors_ = std::move(interiors);
  {
    std::vector<std::pair<glm::dvec3, glm::dvec3>> boxes;
    if (options_.effects & kEffectInteriors)
      for (const InteriorVolume& v : interiors_) boxes.push_back({v.min, v.max});
    cache_.setInteriorBoxes(std::move(boxes));
  }
  interiors_by_sector_.clear();
  for (size_t k = 0; k < interiors_.size(); ++k) {
    const InteriorVolume& v = interiors_[k];
    const SectorKey lo = sectorAt(v.min.x - kInteriorSurfaceSlackM, v.min.y - kInteriorSurfaceSlackM);
    const SectorKey hi = sectorAt(v.max.x + kInteriorSurfaceSlackM, v.max.y + kInteriorSurfaceSlackM);
    const SectorKey at = sectorAt(v.probe_position.x, v.probe_position.y);
    for (int64_t y = lo.iy; y <= hi.iy; ++y)
      for (int64_t x = lo.ix; x <= hi.ix; ++x) interiors_by_sector_[packKey({int32_t(x), int32_t(y)})].push_back(uint32_t(k));
    if (at.ix < lo.ix || at.ix > hi.ix || at.iy < lo.iy || at.iy > hi.iy) interiors_by_sector_[packKey(at)].push_back(uint32_t(k));
  }
  sky_changed_ = true;  // a changed sun path or ground scale: a full relight
  current_ = evaluateSky(sky_, hour_, options_.sun_band1_window, options_.sun_band0_scale);
  resolveInteriors();
  return {};
}

Result<void> Runtime::setTime(double hour) {
  if (!std::isfinite(hour)) return fail("time of day: " + std::to_string(hour) + " h is not a finite number");
  hour_ = hour;
  current_ = evaluateSky(sky_, hour_, options_.sun_band1_window, options_.sun_band0_scale);
  return {};
}

Result<void> Runtime::setLights(std::vector<PointLight> lights) {
  if (auto e = validateLighting(sky_, lights, {}); !e) return std::unexpected(e.error().context("lighting"));
  lights_ = std::move(lights);
  lights_changed_ = true;
  return {};
}

RelightInput Runtime::relightInput() const {
  RelightInput in{applied_.sky_sh, applied_.sun_sh, applied_.sky_direct_sh, lights_, options_.components};
  in.sun_direction = applied_.sun_direction;
  in.sun_irradiance = applied_.sun_irradiance;
  // The bake corrected the linear lobe (transfer.h "The sun transfer"): any other lobe goes without.
  in.sun_transfer = options_.sun_band1_window == kLinearSunBand1 && options_.sun_band0_scale == 0.f;
  return in;
}

float Runtime::hdrScale() const {
  float mx = cache_.maxColour();
  for (const glm::vec3& f : cache_.fallback()) mx = std::max({mx, std::fabs(f.r), std::fabs(f.g), std::fabs(f.b)});
  return std::max(kMinHdrScale, std::min(mx * options_.hdr_headroom, kMaxColour));
}

void Runtime::rescale() {
  BasisColours fallback{};
  const bool sh_l1 = options_.representation == Representation::kShL1;
  if (options_.components & kComponentDirectSky)
    for (int b = 0; b < 4; ++b)
      for (int c = 0; c < 3; ++c)
        fallback[b][c] = sh_l1 ? (b == 0 ? sh::kCosineLobe0 : sh::kCosineLobe1) * applied_.sky_sh[c][b]
                               : std::max(0.f, glm::dot(sh::cosineLobe(sh::kBasis[b]), applied_.sky_sh[c]));
  cache_.setFallback(fallback);
  cache_.pack(hdrScale());
  volume_.invalidateAll();
}

void Runtime::relightMovedLights() {
  const std::vector<int> slots = cache_.relightChangedLights(relightInput());
  if (slots.empty()) return;
  ++light_relights_;
  float mx = 0.f;
  for (int s : slots) mx = std::max(mx, cache_.maxColour(s));
  if (mx > cache_.packedScale() || hdrScale() < kMinScaleKept * cache_.packedScale()) {
    rescale();
    ++light_rescales_;
    return;
  }
  // The nearest fill reads a probe's packed texels only: refill the cells that name a probe whose
  // texels changed (a moving light changes few by a step of 8 bits). The smooth fill reads the
  // float colours: refill the sector.
  const bool nearest = options_.volume.fill == FillMode::kNearest;
  for (int s : slots) {
    const std::bitset<kSlotProbes> changed = cache_.packSlot(s);
    const SectorKey key = cache_.slot(s).key;
    if (!nearest) {
      volume_.invalidateSector(key);
    } else if (changed.any()) {
      const ProbeCache::WorldBox box = cache_.cellsNaming(s, changed);
      if (!box.empty()) volume_.invalidateBox(key, box.lo, box.hi);
    }
  }
}

Result<void> Runtime::addSector(const Sector& sector, const OcclusionTile* tile, SectorBlock block) {
  if (tile) DRTV_CHECK(tile->key == sector.key);
  if (auto r = cache_.addSector(sector, block); !r) return r;
  fine_stale_ = true;
  if (options_.effects & kEffectDistantOcclusion) occlusion_.add(tile ? *tile : makeOcclusionTile(sector));
  resolveInteriors(sector.key);
  // And those whose designated probe came with it wherever it stands (an archive may put one
  // outside the sectors its box lies over).
  for (const ProbeRecord& r : sector.probes) {
    const ProbeData d = unpackProbe(r);
    if ((d.flags & kProbeInterior) && d.interior >= 1 && d.interior <= interiors_.size()) {
      const InteriorVolume& v = interiors_[d.interior - 1u];
      interior_probes_[d.interior - 1u] = cache_.interiorProbe(d.interior, v.probe_position, v.min, v.max);
    }
  }
  if (!relit_once_) return {};  // the first update() relights everything
  if (!lights_.empty() && (options_.components & kComponentLocalLights)) {
    // New sources may take shares of the lights from probes of resident neighbours, so the next
    // update() redistributes the lights (relightMovedLights), and that relights this slot, never
    // relit, with the slots whose shares changed. Relighting it here as well distributed every
    // light twice per lit arrival (perf of the lit-island fly, docs/runtime.md).
    lights_changed_ = true;
    volume_.invalidateSector(sector.key);
    return {};
  }
  cache_.relightSector(sector.key, relightInput());
  const int slot = cache_.slotOf(sector.key);
  if (cache_.maxColour(slot) > cache_.packedScale()) {
    rescale();
  } else {
    cache_.packSlot(slot);
    volume_.invalidateSector(sector.key);
  }
  return {};
}

bool Runtime::removeSector(SectorKey key) {
  const int slot = cache_.slotOf(key);
  if (!cache_.removeSector(key)) return false;
  fine_stale_ = true;
  occlusion_.remove(key);
  resolveInteriors(key);
  // An interior whose probe stood in the departed slot (a designated probe an archive put outside
  // the sectors its box lies over) is resolved again too: no reference outlives its slot.
  for (size_t k = 0; k < interior_probes_.size(); ++k)
    if (interior_probes_[k].slot == slot) interior_probes_[k] = cache_.interiorProbe(uint16_t(k + 1), interiors_[k].probe_position, interiors_[k].min, interiors_[k].max);
  volume_.invalidateSector(key);
  if (!lights_.empty()) lights_changed_ = true;  // the shares its sources held go elsewhere
  return true;
}

void Runtime::resolveInteriors(std::optional<SectorKey> key) {
  // The designated probe is flagged kProbeInterior and belongs to interior k + 1 (probe.h); without
  // one resident, the resident probe inside the box nearest the artist's position. Both lie over
  // the sectors interiors_by_sector_ lists the interior under.
  auto resolve = [&](size_t k) {
    const InteriorVolume& v = interiors_[k];
    interior_probes_[k] = cache_.interiorProbe(uint16_t(k + 1), v.probe_position, v.min, v.max);
  };
  if (!key || interior_probes_.size() != interiors_.size()) {
    interior_probes_.assign(interiors_.size(), ProbeRef{});
    for (size_t k = 0; k < interiors_.size(); ++k) resolve(k);
    return;
  }
  if (const std::vector<uint32_t>* over = interiorsOver(*key))
    for (const uint32_t k : *over) resolve(k);
}

void Runtime::update(const glm::dvec3& camera) {
  if (!relit_once_ || sky_changed_ || lightingChange(applied_, current_) > options_.relight_threshold) {
    applied_ = current_;
    cache_.relightAll(relightInput());
    rescale();
    relit_once_ = true;
    sky_changed_ = lights_changed_ = false;
    ++relights_;
    fine_stale_ = true;
  } else if (lights_changed_) {
    // Only the lights moved: the sky and sun are those every slot was last relit with.
    lights_changed_ = false;
    relightMovedLights();
    fine_stale_ = true;
  }
  volume_.update(volumeOriginFor(options_.volume, camera), cache_);
  if (options_.fine_shader) {
    FineShaderOptions o = *options_.fine_shader;
    o.lookup = options_.fine;
    const glm::dvec3 corner = fineBoxCorner(camera, o);
    if (fine_stale_ || corner != fine_corner_) {  // NaN (a non-finite camera) never equals: packed (empty) each time
      auto level = std::make_shared<const FineShaderData>(packFineLevel(cache_, camera, o));
      fine_stale_ = false;
      fine_corner_ = corner;
      std::lock_guard lock(fine_mutex_);
      fine_level_ = std::move(level);
    }
  }
}

AmbientSample Runtime::ambient(const glm::dvec3& position, const glm::vec3& normal) const {
  const glm::vec3 n = ambientNormal(normal);
  AmbientSample s;
  static const OcclusionMap kOpenSky;
  const sh::Sh4Rgb sky = options_.components & kComponentDirectSky ? applied_.sky_sh : sh::Sh4Rgb{};
  s.distant = distantAmbient(options_.effects & kEffectDistantOcclusion ? occlusion_ : kOpenSky, sky, position, n);
  {
    const PublishedVolume::ReadView view = volume_.read();
    const glm::dvec3 sample = position + glm::dvec3(n) * double(options_.normal_offset_m);
    s.volume_weight = view->coverage(sample, options_.edge_fade_texels);
    if (s.volume_weight > 0.f)
      switch (options_.volume_lookup) {
        case RuntimeOptions::VolumeLookup::kFacing: s.volume = sampleVolumeFacing(view.volume(), position, n, options_.normal_offset_m); break;
        case RuntimeOptions::VolumeLookup::kSided:
          s.volume = sampleVolumeSided(view.volume(), cache_, position, n, options_.normal_offset_m);
          break;
        case RuntimeOptions::VolumeLookup::kTrilinear: s.volume = sampleVolume(view.volume(), position, n, options_.normal_offset_m); break;
      }
  }
  s.irradiance = s.distant + (s.volume - s.distant) * s.volume_weight;
  const std::vector<uint32_t>* over = (options_.effects & kEffectInteriors) ? interiorsOver(sectorAt(position.x, position.y)) : nullptr;
  if (over) {
    // Only interiors whose box (grown by the slack) lies over the point's sector can hold it.
    for (const uint32_t k : *over) {
      if (!interior_probes_[k].valid()) continue;
      const InteriorVolume& v = interiors_[k];
      auto depthIn = [&](const glm::dvec3& q) {
        const glm::dvec3 lo = q - v.min, hi = v.max - q;
        return std::min({lo.x, lo.y, lo.z, hi.x, hi.y, hi.z});
      };
      const double depth = depthIn(position);
      float t = 0.f;
      if (depth >= -kInteriorSurfaceSlackM && depthIn(position + glm::dvec3(n) * double(options_.normal_offset_m)) > 0.0)
        t = 1.f;  // a surface of the room, facing into it (an artist's box is the room's inside: its surfaces lie on its faces)
      else if (depth >= 0.0)
        t = v.blend_distance_m > 0.f ? float(std::min(1.0, depth / v.blend_distance_m)) : 1.f;
      else
        continue;
      if (t <= s.interior_weight && s.interior >= 0) continue;
      s.interior = int(k);
      s.interior_weight = t;
    }
    if (s.interior >= 0) {
      s.interior_ambient = shade(options_.representation, cache_.colours(interior_probes_[s.interior]), n);
      s.irradiance += (s.interior_ambient - s.irradiance) * s.interior_weight;
    }
  }
  if (options_.fine.enabled) {
    const FineSample f = cache_.fineLookup(position, n, options_.fine);
    if (f.weight > 0.f) {
      s.fine_weight = f.weight;
      s.fine = shade(options_.representation, f.colours, n);
      s.irradiance += (s.fine - s.irradiance) * s.fine_weight;
    }
  }
  return s;
}

std::optional<BasisColours> Runtime::nearestProbeColours(const glm::dvec3& position) const {
  const ProbeRef p = cache_.probeAt(position);
  if (!p.valid()) return std::nullopt;
  return cache_.colours(p);
}

Result<std::unique_ptr<Runtime>> runtimeForArchive(const Manifest& manifest, const RuntimeOptions& options, double hour,
                                                   const std::vector<PointLight>* lights) {
  RuntimeOptions o = options;
  o.representation = manifest.representation;  // the archive's, whatever the caller picked
  auto rt = std::make_unique<Runtime>(o);
  if (auto r = rt->setLighting(manifest.sky, lights ? *lights : manifest.lights, manifest.interiors); !r)
    return std::unexpected(r.error());
  if (auto r = rt->setTime(hour); !r) return std::unexpected(r.error());
  return rt;
}

Result<std::unique_ptr<Runtime>> runtimeForSectors(const Manifest& manifest, const RuntimeOptions& options, double hour,
                                                   std::span<const Sector> sectors, const std::vector<PointLight>* lights) {
  RuntimeOptions o = options;
  o.cache.max_sectors = std::max<int>(o.cache.max_sectors, int(std::min<size_t>(sectors.size(), size_t(std::numeric_limits<int>::max()))));
  auto made = runtimeForArchive(manifest, o, hour, lights);
  if (!made) return std::unexpected(made.error());
  for (const Sector& s : sectors)
    if (auto r = (*made)->addSector(s); !r) return std::unexpected(r.error().context("sector " + toString(s.key)));
  return made;
}

}  // namespace drtv::runtime
