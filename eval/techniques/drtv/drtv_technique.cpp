// DRTV as a technique (technique.h): the baker's transfer bake in memory, then drtv::runtime set up
// as an engine sets it up from an archive (runtime::runtimeForArchive) holding every sector of the
// block. Its knobs are parameters; the first five need a bake, the others only a new runtime:
//   quality            draft | default | high       the bake preset (BakeSettings::forQuality)
//   rays_per_basis     integer >= 1                 overrides the preset's transfer rays
//   bounces            integer >= 1                 overrides the preset's bounces
//   sweeps             1..256                       Jacobi sweeps over the surface cache
//                                                   (transfer.h; default bounces - 1)
//   covered_spacing    metres in (0, 64]            the column lattice under roofs
//   covered_min_h      metres in (0, 64]            the minimum distance between probes under
//                                                   roofs (placement.h, issue 16)
//   rooms              auto | off                   closed rooms found at bake time get
//                                                   interiors (rooms.h, issue 16; default auto)
//   representation     fc3 | sh-l1                  the directional representation baked
//                                                   (representation.h; default sh-l1)
//   fill               nearest | smooth             the volume fill (runtime FillMode)
//   lookup             trilinear | facing           how ambient reads the volume: the shaders'
//                                                   filter, or without the texels behind the
//                                                   surface (runtime::sampleVolumeFacing)
//   texel_m            metres in (0, 1e4]           the volume's horizontal texel size (the
//                                                   vertical one twice it, as the default 2 x 4 m)
//   sun_window         hanning | lanczos | none | linear
//                                                   the sun's SH lobe (lighting_sh.h; default:
//                                                   the representation's, hanning for fc3,
//                                                   linear for sh-l1)
//   part               all | sun_bounce | sky_bounce | direct_sky | local_lights
//                                                   one relighting term alone (the reference's
//                                                   parts of the same names)
//   sources_per_light  1..64                        LPRT source probes one light is spread onto
//   light_sources      visible | nearest            which probes those are (probe_cache.h)
//   lprt_sources       integer >= 1                 keep the first N LPRT sources of each sector
//                                                   (they are sorted nearest first, bake.cpp)
//   storage            runtime | 8-bit | snorm8 | 16-bit | float
//                                                   the volume's precision, emulated outside the
//                                                   runtime (nearest fill, no blur, trilinear over
//                                                   texels, the representation's shading). 8-bit
//                                                   and 16-bit are the runtime's encodings at that
//                                                   width (sh-l1: e0 unsigned, e1..3 signed about
//                                                   the mid code, representation.h); snorm8 (sh-l1
//                                                   only) stores e0 signed as well, in 127 steps
// Registered as "drtv" and as the variants "drtv-nearest" and "drtv-smooth".
#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <optional>

#include "drtv/baker/bake.h"
#include "drtv/formats/sh.h"
#include "drtv/runtime/runtime.h"
#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;

struct BakeParams {
  baker::Quality quality = baker::Quality::kDefault;
  std::optional<int> rays_per_basis, bounces, sweeps;
  std::optional<double> covered_spacing, covered_min_h;  // placement under roofs (placement.h)
  Representation representation = Representation::kShL1;  // the baker's default for new worlds
  bool rooms = true;  // the room search (rooms.h)
  bool cell_sides = true;  // cache cells split by walls (transfer.h TransferSettings::cell_sides)
  bool operator==(const BakeParams&) const = default;
};

struct RuntimeParams {
  runtime::FillMode fill = runtime::FillMode::kNearest;
  runtime::RuntimeOptions::VolumeLookup lookup = runtime::RuntimeOptions::VolumeLookup::kTrilinear;
  std::optional<float> texel_m;
  std::optional<float> sun_window;
  float sun_band0 = 1.f;
  std::optional<uint32_t> part;  // a runtime component
  std::optional<int> sources_per_light;
  std::optional<runtime::LightSources> light_sources;
  std::optional<size_t> lprt_sources;
  double storage_levels = -1;  // < 0: the runtime's volume; 0: float; else steps per HDR unit
  bool storage_signed_e0 = false;  // sh-l1: e0 in the signed code of e1..3 (storage=snorm8)
  double storage_bytes = 12;   // per texel, the three textures together
};

struct Params {
  BakeParams bake;
  RuntimeParams runtime;
  TechniqueParams given;
};

Result<Params> parseParams(const TechniqueParams& p) {
  Params out;
  out.given = p;
  for (const auto& [k, v] : p) {
    if (k == "quality") {
      auto q = baker::parseQuality(v);
      if (!q) return fail("quality=" + v + ": expected draft, default or high");
      out.bake.quality = *q;
    } else if (k == "rays_per_basis" || k == "bounces") {
      auto x = intIn(k, v, 1, 1 << 20);
      if (!x) return std::unexpected(x.error());
      (k == "bounces" ? out.bake.bounces : out.bake.rays_per_basis) = *x;
    } else if (k == "sweeps") {
      auto x = intIn(k, v, 1, 256);
      if (!x) return std::unexpected(x.error());
      out.bake.sweeps = *x;
    } else if (k == "covered_spacing" || k == "covered_min_h") {
      double x = 0;
      const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
      if (ec != std::errc() || end != v.data() + v.size() || !(x > 0 && x <= 64)) return fail(k + "=" + v + ": expected metres in (0, 64]");
      (k == "covered_spacing" ? out.bake.covered_spacing : out.bake.covered_min_h) = x;
    } else if (k == "rooms") {
      if (v == "auto") out.bake.rooms = true;
      else if (v == "off") out.bake.rooms = false;
      else return fail("rooms=" + v + ": expected auto or off");
    } else if (k == "cache_cells") {
      if (v == "sides") out.bake.cell_sides = true;
      else if (v == "shared") out.bake.cell_sides = false;
      else return fail("cache_cells=" + v + ": expected sides or shared");
    } else if (k == "fill") {
      if (v == "nearest") out.runtime.fill = runtime::FillMode::kNearest;
      else if (v == "smooth") out.runtime.fill = runtime::FillMode::kSmooth;
      else return fail("fill=" + v + ": expected nearest or smooth");
    } else if (k == "lookup") {
      if (v == "trilinear") out.runtime.lookup = runtime::RuntimeOptions::VolumeLookup::kTrilinear;
      else if (v == "facing") out.runtime.lookup = runtime::RuntimeOptions::VolumeLookup::kFacing;
      else return fail("lookup=" + v + ": expected trilinear or facing");
    } else if (k == "texel_m") {
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (end != v.c_str() + v.size() || !(x > 0.0) || !std::isfinite(x) || x > 1e4) return fail("texel_m=" + v + ": expected metres in (0, 1e4]");
      out.runtime.texel_m = float(x);
    } else if (k == "sun_window") {
      if (v == "hanning") out.runtime.sun_window = runtime::kHanningBand1;
      else if (v == "lanczos") out.runtime.sun_window = runtime::kLanczosBand1;
      else if (v == "none") out.runtime.sun_window = runtime::kNoWindowBand1;
      else if (v == "linear") out.runtime.sun_window = runtime::kLinearSunBand1, out.runtime.sun_band0 = 0.f;
      else return fail("sun_window=" + v + ": expected hanning, lanczos, none or linear");
    } else if (k == "representation") {
      auto r = parseRepresentation(v);
      if (!r) return fail("representation=" + v + ": expected one of " + representationNames());
      out.bake.representation = *r;
    } else if (k == "part") {
      if (v == "all") out.runtime.part.reset();
      else if (v == "sun_bounce") out.runtime.part = runtime::kComponentSunBounce;
      else if (v == "sky_bounce") out.runtime.part = runtime::kComponentSkyBounce;
      else if (v == "direct_sky") out.runtime.part = runtime::kComponentDirectSky;
      else if (v == "local_lights") out.runtime.part = runtime::kComponentLocalLights;
      else return fail("part=" + v + ": expected all, sun_bounce, sky_bounce, direct_sky or local_lights");
    } else if (k == "sources_per_light") {
      auto x = intIn(k, v, 1, 64);
      if (!x) return std::unexpected(x.error());
      out.runtime.sources_per_light = *x;
    } else if (k == "light_sources") {
      if (v == "visible") out.runtime.light_sources = runtime::LightSources::kVisibleFromLight;
      else if (v == "nearest") out.runtime.light_sources = runtime::LightSources::kNearest;
      else return fail("light_sources=" + v + ": expected visible or nearest");
    } else if (k == "lprt_sources") {
      auto x = intIn(k, v, 1, 1 << 16);
      if (!x) return std::unexpected(x.error());
      out.runtime.lprt_sources = size_t(*x);
    } else if (k == "storage") {
      out.runtime.storage_signed_e0 = v == "snorm8";
      if (v == "runtime") out.runtime.storage_levels = -1, out.runtime.storage_bytes = 12;
      else if (v == "8-bit" || v == "snorm8") out.runtime.storage_levels = 255.0, out.runtime.storage_bytes = 12;
      else if (v == "16-bit") out.runtime.storage_levels = 65535.0, out.runtime.storage_bytes = 24;
      else if (v == "float") out.runtime.storage_levels = 0.0, out.runtime.storage_bytes = 48;
      else return fail("storage=" + v + ": expected runtime, 8-bit, snorm8, 16-bit or float");
    } else {
      return fail("no parameter '" + k +
                  "' (drtv takes quality, rays_per_basis, bounces, sweeps, covered_spacing, covered_min_h, rooms, cache_cells, representation, fill, lookup, texel_m, sun_window, part, "
                  "sources_per_light, light_sources, lprt_sources, storage)");
    }
  }
  if (out.runtime.storage_signed_e0 && out.bake.representation != Representation::kShL1)
    return fail("storage=snorm8: a signed e0 is an sh-l1 encoding; it takes representation=sh-l1 only");
  return out;
}

baker::BakeSettings bakeSettings(const BakeParams& p, uint64_t seed) {
  baker::BakeSettings s = baker::BakeSettings::forQuality(p.quality, seed);
  if (p.rays_per_basis) s.transfer.probe_rays_per_basis = *p.rays_per_basis;
  if (p.bounces) s.transfer.bounces = *p.bounces;
  if (p.sweeps) s.transfer.sweeps = *p.sweeps;
  if (p.covered_spacing) s.placement.covered_column_spacing_m = *p.covered_spacing;
  if (p.covered_min_h) s.placement.covered_min_horizontal_m = *p.covered_min_h;
  s.transfer.representation = p.representation;
  s.rooms.enabled = p.rooms;
  s.transfer.cell_sides = p.cell_sides;
  return s;
}

// Keeps the first `keep` LPRT sources of every sector.
std::vector<Sector> truncateLprt(const std::vector<Sector>& sectors, size_t keep) {
  std::vector<Sector> out = sectors;
  for (Sector& s : out) {
    const size_t S = s.lprt.sources.size();
    if (S <= keep) continue;
    std::vector<int16_t> coeffs(s.probes.size() * keep * 12);
    for (size_t p = 0; p < s.probes.size(); ++p)
      for (size_t j = 0; j < keep; ++j)
        for (int k = 0; k < 12; ++k) coeffs[(p * keep + j) * 12 + k] = s.lprt.coeffs[(p * S + j) * 12 + k];
    s.lprt.coeffs = std::move(coeffs);
    s.lprt.sources.resize(keep);
  }
  return out;
}

size_t storedBytes(const std::vector<Sector>& sectors) {
  size_t n = 0;
  for (const Sector& s : sectors) n += encodedSectorBytes(s.probes.size(), s.lprt.sources.size(), s.has_ground, s.sun ? s.sun->samples() : 0);
  return n;
}

class DrtvTechnique final : public Technique {
 public:
  DrtvTechnique(std::string name, Params params) : name_(std::move(name)), params_(std::move(params)) {}

  Result<void> prepare(const PrepareInput& in) override {
    const baker::BakeSettings s = bakeSettings(params_.bake, in.seed);
    if (in.baked && in.baked->manifest.settings == s.describe()) {
      adopt(in.baked->manifest, in.baked->sectors, in.baked->bake_s);
      return {};
    }
    auto b = baker::bakeInMemory(in.world, in.where, s, in.block, in.threads);
    if (!b) return std::unexpected(b.error());
    adopt(std::move(b->manifest), std::move(b->sectors), b->bake_s);
    return {};
  }

  Result<void> prepareBaked(const Manifest& manifest, std::span<const Sector> sectors) override {
    adopt(manifest, std::vector<Sector>(sectors.begin(), sectors.end()), 0.0);
    return {};
  }

  Result<void> setParams(const TechniqueParams& params) override {
    auto p = parseParams(params);
    if (!p) return std::unexpected(p.error());
    if (!(p->bake == params_.bake)) return fail("technique " + describe() + ": bake parameters change only with a new prepare");
    const bool lprt_changed = p->runtime.lprt_sources != params_.runtime.lprt_sources;
    TechniqueParams given = params;
    params_ = std::move(*p);
    params_.given = std::move(given);
    if (lprt_changed) resetSectors();
    rt_.reset();
    return {};
  }

  Result<void> setLighting(double hour, const std::vector<PointLight>& lights) override {
    if (!rt_) {
      options_ = runtimeOptions(manifest_.effects);
      // An evaluation reads the lighting of the hour it set: every update publishes its own
      // refill (an engine's blurred refill takes two frames, publish.h; the fly keeps that).
      options_.volume_rebuild_updates = 1;
      const RuntimeParams& p = params_.runtime;
      options_.cache.max_sectors = std::max<int>(options_.cache.max_sectors, int(active().size()));
      auto rt = runtime::runtimeForArchive(manifest_, options_, hour, &lights);
      if (!rt) return std::unexpected(rt.error());
      for (const Sector& s : active())
        if (auto r = (*rt)->addSector(s); !r) return std::unexpected(r.error().context("sector " + toString(s.key)));
      rt_ = std::move(*rt);
      const glm::ivec3 n = options_.volume.size;
      costs_.runtime_bytes = size_t(double(n.x) * n.y * n.z * p.storage_bytes);
      return {};
    }
    if (auto r = rt_->setLights(lights); !r) return std::unexpected(r.error());
    return rt_->setTime(hour);
  }

  Result<void> update(const glm::dvec3& camera) override {
    if (!rt_) return fail("technique " + describe() + ": update before setLighting");
    const auto t0 = Clock::now();
    rt_->update(camera);
    costs_.update_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return {};
  }

  glm::vec3 ambient(const glm::dvec3& position, const glm::vec3& normal) const override {
    if (!rt_) return glm::vec3(0.f);
    if (params_.runtime.storage_levels >= 0) return emulated(position, normal);
    return rt_->ambient(position, normal).irradiance;
  }

  TechniqueCosts costs() const override { return costs_; }

  std::optional<runtime::RuntimeOptions> streamingRuntime(const Manifest& manifest) const override {
    if (params_.runtime.storage_levels >= 0 || params_.runtime.lprt_sources) return std::nullopt;  // emulations
    return runtimeOptions(manifest.effects);
  }

  std::string describe() const override { return describeTechnique(name_, params_.given); }

 private:
  // optionsForEffects (what an engine picks for the archive) with this technique's parameters.
  runtime::RuntimeOptions runtimeOptions(uint32_t effects) const {
    runtime::RuntimeOptions o = runtime::optionsForEffects(effects);
    const RuntimeParams& p = params_.runtime;
    o.volume.fill = p.fill;
    o.volume_lookup = p.lookup;
    if (p.texel_m) o.volume.texel_size_m = glm::vec3(*p.texel_m, *p.texel_m, 2.f * *p.texel_m);
    if (p.sun_window) o.sun_band1_window = *p.sun_window, o.sun_band0_scale = p.sun_band0;
    if (p.part) o.components = *p.part;
    if (p.sources_per_light) o.cache.sources_per_light = *p.sources_per_light;
    if (p.light_sources) o.cache.light_sources = *p.light_sources;
    if (p.storage_levels >= 0) o.volume.blur = false;
    return o;
  }

  void adopt(Manifest manifest, std::vector<Sector> sectors, double bake_s) {
    manifest_ = std::move(manifest);
    baked_ = std::move(sectors);
    costs_.prepare_s = bake_s;
    resetSectors();
    rt_.reset();
  }

  void resetSectors() {
    truncated_.clear();
    if (params_.runtime.lprt_sources) truncated_ = truncateLprt(baked_, *params_.runtime.lprt_sources);
    costs_.stored_bytes = storedBytes(active());
  }

  const std::vector<Sector>& active() const { return params_.runtime.lprt_sources ? truncated_ : baked_; }

  // The volume at `levels` codes per unit of the HDR scale (0 = float), emulated from the cache:
  // the nearest probe at each of the 8 texel centres around the shading point, trilinear, then
  // the representation's shading (runtime::shade). An unsigned coefficient takes `levels` steps
  // over [0, scale]; a signed one (sh-l1's e1..3, and e0 under snorm8) floor(levels / 2) steps
  // over [-scale, scale], as the runtime's offset-binary code does (pack.h).
  glm::vec3 emulated(const glm::dvec3& position, const glm::vec3& normal) const {
    const runtime::ProbeCache& cache = rt_->cache();
    const Representation rep = cache.representation();
    const double levels = params_.runtime.storage_levels;
    const double scale = cache.packedScale();
    const double half = std::floor(levels / 2.0);
    auto quantise = [&](float x, int b) {
      if (levels <= 0.0) return x;
      const bool is_signed = rep == Representation::kShL1 && (b > 0 || params_.runtime.storage_signed_e0);
      const double q = is_signed ? std::round(std::clamp(double(x) / scale, -1.0, 1.0) * half) / half
                                 : std::round(std::clamp(double(x) / scale, 0.0, 1.0) * levels) / levels;
      return float(q * scale);
    };
    const glm::dvec3 ts(options_.volume.texel_size_m);
    const glm::dvec3 s = position + glm::dvec3(normal) * double(options_.normal_offset_m);
    const glm::dvec3 t = s / ts - 0.5;
    const glm::dvec3 g0 = glm::floor(t), f = t - g0;
    std::array<glm::vec3, 4> colour{};
    for (int corner = 0; corner < 8; ++corner) {
      const glm::dvec3 g = g0 + glm::dvec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
      const double w = (corner & 1 ? f.x : 1 - f.x) * (corner & 2 ? f.y : 1 - f.y) * (corner & 4 ? f.z : 1 - f.z);
      const runtime::ProbeRef pr = cache.probeAt((g + 0.5) * ts);
      const runtime::BasisColours c = pr.valid() ? cache.colours(pr) : cache.fallback();
      for (int b = 0; b < 4; ++b)
        for (int ch = 0; ch < 3; ++ch) colour[b][ch] += float(w) * quantise(c[b][ch], b);
    }
    return runtime::shade(rep, colour, normal);
  }

  std::string name_;
  Params params_;
  Manifest manifest_;
  std::vector<Sector> baked_, truncated_;
  runtime::RuntimeOptions options_;
  std::unique_ptr<runtime::Runtime> rt_;
  TechniqueCosts costs_;
};

TechniqueFactory factoryFor(std::string name) {
  return [name](const TechniqueParams& p) -> Result<std::unique_ptr<Technique>> {
    auto parsed = parseParams(p);
    if (!parsed) return std::unexpected(parsed.error());
    return std::make_unique<DrtvTechnique>(name, std::move(*parsed));
  };
}

}  // namespace

std::vector<TechniqueRegistration> drtvTechniques() {
  std::vector<TechniqueRegistration> out;
  out.push_back({{"drtv", "Deferred Radiance Transfer Volumes (GDC 2012): baked probe transfer, relit per frame, a camera volume", {}},
                 factoryFor("drtv")});
  out.push_back({{"drtv-nearest", "DRTV, each volume texel from the probe its index cell names (the talk's fill)", {{"fill", "nearest"}}},
                 factoryFor("drtv-nearest")});
  out.push_back({{"drtv-smooth", "DRTV, each volume texel trilinear over the index cells around it", {{"fill", "smooth"}}},
                 factoryFor("drtv-smooth")});
  return out;
}

}  // namespace drtv::eval
