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
//   enclosed_spacing   metres in [0, 64]            the column lattice and least distance in
//                                                   enclosed spaces under roofs (placement.h,
//                                                   issue 35; default 2; 0 = the covered values)
//   covered_stack      metres in [0, 64]            under a roof, a probe every this many metres
//                                                   up a space taller than a storey (placement.h,
//                                                   issue 35; default 3; 0 = one per floor)
//   rooms              auto | off                   closed rooms found at bake time get
//                                                   interiors (rooms.h, issue 16; default auto)
//   visibility_rays    64..16384                    rays of a covered probe's visibility map
//                                                   (BakeSettings::visibility_rays; default 1024)
//   grid_sides         same | any                   index cells name probes on their own side
//                                                   of the sky line (index_grid.h, issue 35;
//                                                   default same)
//   covered_sight      on | off                     a covered probe keeps others away only where
//                                                   they see each other (placement.h, issue 35;
//                                                   default on)
//   openings           on | off                     covered probes' visibility maps end where a ray
//                                                   leaves the covered air (visibility_bake.h,
//                                                   issue 35; default on)
//   thinning           near-first | even            a sector over the 255 cap thins its probes
//                                                   under roofs first (placement.h, issue 35;
//                                                   default near-first)
//   own_sources        on | off                     LPRT sources where the baked lights stand
//                                                   (BakeSettings::light_sources, issue 35;
//                                                   default on)
//   representation     fc3 | sh-l1                  the directional representation baked
//                                                   (representation.h; default sh-l1)
//   fill               nearest | smooth             the volume fill (runtime FillMode)
//   lookup             trilinear | facing | sided   how ambient reads the volume: the shaders'
//                                                   filter, or without the texels behind the
//                                                   surface (runtime::sampleVolumeFacing), or
//                                                   without those behind it on the sky line's
//                                                   other side (runtime::sampleVolumeSided)
//   fine               on | off                     the fine level near surfaces (probe_cache.h
//                                                   fineLookup, issue 35; default on)
//   fine_radius, fine_bias, fine_min_visibility, fine_full_weight
//                      reals                        its FineOptions (probe_cache.h)
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
#include <sstream>

#include "drtv/baker/bake.h"
#include "drtv/baker/placement.h"
#include "drtv/reference/reference.h"
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
  std::optional<double> enclosed_spacing;                // in enclosed spaces (placement.h); 0 = covered
  std::optional<double> covered_stack;                   // up tall spaces under roofs (placement.h); 0 = off
  Representation representation = Representation::kShL1;  // the baker's default for new worlds
  bool rooms = true;  // the room search (rooms.h)
  bool cell_sides = true;  // cache cells split by walls (transfer.h TransferSettings::cell_sides)
  bool own_sources = true;  // LPRT sources where the baked lights stand (BakeSettings::light_sources)
  bool grid_same_side = true;  // index cells on their own side of the sky line (IndexGridSettings::same_side)
  bool covered_sight = true;   // probes apart only where they see each other (PlacementSettings::covered_sight)
  bool thin_near_first = true;  // over the cap, the probes under roofs thin first (PlacementSettings::thin_near_first)
  bool openings = true;        // visibility maps end at the covered air's openings (BakeSettings::visibility_openings)
  std::optional<int> visibility_rays;  // BakeSettings::visibility_rays
  bool operator==(const BakeParams&) const = default;
};

struct RuntimeParams {
  runtime::FillMode fill = runtime::FillMode::kNearest;
  runtime::RuntimeOptions::VolumeLookup lookup = runtime::RuntimeOptions::VolumeLookup::kTrilinear;
  bool fine = true;
  std::optional<float> fine_radius, fine_bias, fine_min_visibility, fine_full_weight;
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
};

// storage=...: steps per HDR unit (< 0 the runtime's volume, 0 float), e0 signed, bytes per texel.
struct Storage {
  double levels = -1;
  bool signed_e0 = false;
  double bytes = 12;
};

Params readDrtv(ParamReader& r) {
  Params out;
  if (const std::string* v = r.text("quality")) {
    if (auto q = baker::parseQuality(*v)) out.bake.quality = *q;
    else r.reject("quality=" + *v + ": expected draft, default or high");
  }
  r.integer("rays_per_basis", out.bake.rays_per_basis, 1, 1 << 20)
      .integer("bounces", out.bake.bounces, 1, 1 << 20)
      .integer("sweeps", out.bake.sweeps, 1, 256)
      .integer("visibility_rays", out.bake.visibility_rays, 64, 16384)
      .real("covered_spacing", out.bake.covered_spacing, 0, 64, true)
      .real("covered_min_h", out.bake.covered_min_h, 0, 64, true)
      .real("enclosed_spacing", out.bake.enclosed_spacing, 0, 64, false)
      .real("covered_stack", out.bake.covered_stack, 0, 64, false)
      .oneOf("rooms", out.bake.rooms, {{"auto", true}, {"off", false}})
      .oneOf("cache_cells", out.bake.cell_sides, {{"sides", true}, {"shared", false}})
      .oneOf("own_sources", out.bake.own_sources, {{"on", true}, {"off", false}})
      .oneOf("grid_sides", out.bake.grid_same_side, {{"same", true}, {"any", false}})
      .oneOf("covered_sight", out.bake.covered_sight, {{"on", true}, {"off", false}})
      .oneOf("openings", out.bake.openings, {{"on", true}, {"off", false}})
      .oneOf("thinning", out.bake.thin_near_first, {{"near-first", true}, {"even", false}});
  if (const std::string* v = r.text("representation")) {
    if (auto rep = parseRepresentation(*v)) out.bake.representation = *rep;
    else r.reject("representation=" + *v + ": expected one of " + representationNames());
  }
  r.oneOf("fill", out.runtime.fill, {{"nearest", runtime::FillMode::kNearest}, {"smooth", runtime::FillMode::kSmooth}})
      .oneOf("lookup", out.runtime.lookup,
             {{"trilinear", runtime::RuntimeOptions::VolumeLookup::kTrilinear}, {"facing", runtime::RuntimeOptions::VolumeLookup::kFacing},
              {"sided", runtime::RuntimeOptions::VolumeLookup::kSided}})
      .oneOf("fine", out.runtime.fine, {{"on", true}, {"off", false}})
      .real("fine_radius", out.runtime.fine_radius, 0, 64, true)
      .real("fine_bias", out.runtime.fine_bias, 0, 4, false)
      .real("fine_min_visibility", out.runtime.fine_min_visibility, 0, 1, false)
      .real("fine_full_weight", out.runtime.fine_full_weight, 0, 100, true)
      .real("texel_m", out.runtime.texel_m, 0, 1e4, true);
  std::pair<std::optional<float>, float> window{std::nullopt, 1.f};  // band 1, band 0 scale
  r.oneOf("sun_window", window,
          {{"hanning", {runtime::kHanningBand1, 1.f}}, {"lanczos", {runtime::kLanczosBand1, 1.f}},
           {"none", {runtime::kNoWindowBand1, 1.f}}, {"linear", {runtime::kLinearSunBand1, 0.f}}});
  out.runtime.sun_window = window.first, out.runtime.sun_band0 = window.second;
  readPart(r, out.runtime.part);
  r.integer("sources_per_light", out.runtime.sources_per_light, 1, 64)
      .oneOf("light_sources", out.runtime.light_sources,
             {{"visible", std::optional(runtime::LightSources::kVisibleFromLight)}, {"nearest", std::optional(runtime::LightSources::kNearest)}})
      .integer("lprt_sources", out.runtime.lprt_sources, 1, 1 << 16);
  Storage st;
  r.oneOf("storage", st,
          {{"runtime", Storage{-1, false, 12}}, {"8-bit", Storage{255.0, false, 12}}, {"snorm8", Storage{255.0, true, 12}},
           {"16-bit", Storage{65535.0, false, 24}}, {"float", Storage{0.0, false, 48}}});
  out.runtime.storage_levels = st.levels, out.runtime.storage_signed_e0 = st.signed_e0, out.runtime.storage_bytes = st.bytes;
  if (out.runtime.storage_signed_e0 && out.bake.representation != Representation::kShL1)
    r.reject("storage=snorm8: a signed e0 is an sh-l1 encoding; it takes representation=sh-l1 only");
  return out;
}

baker::BakeSettings bakeSettings(const BakeParams& p, uint64_t seed) {
  baker::BakeSettings s = baker::BakeSettings::forQuality(p.quality, seed);
  if (p.rays_per_basis) s.transfer.probe_rays_per_basis = *p.rays_per_basis;
  if (p.bounces) s.transfer.bounces = *p.bounces;
  if (p.sweeps) s.transfer.sweeps = *p.sweeps;
  if (p.covered_spacing) s.placement.covered_column_spacing_m = *p.covered_spacing;
  if (p.covered_min_h) s.placement.covered_min_horizontal_m = *p.covered_min_h;
  if (p.enclosed_spacing) s.placement.setEnclosedSpacing(*p.enclosed_spacing);
  if (p.covered_stack) s.placement.covered_stack_m = *p.covered_stack;
  s.transfer.representation = p.representation;
  s.rooms.enabled = p.rooms;
  s.transfer.cell_sides = p.cell_sides;
  s.light_sources = p.own_sources;
  s.grid.same_side = p.grid_same_side;
  s.placement.covered_sight = p.covered_sight;
  s.visibility_openings = p.openings;
  s.placement.thin_near_first = p.thin_near_first;
  if (p.visibility_rays) s.visibility_rays = *p.visibility_rays;
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
  for (const Sector& s : sectors) n += encodedSectorBytes(s.probes.size(), s.lprt.sources.size(), s.has_ground, s.sun ? s.sun->samples() : 0, coveredProbes(s));
  return n;
}

class DrtvTechnique final : public Technique {
 public:
  using Params = drtv::eval::Params;
  DrtvTechnique(TechniqueMade made, Params params) : Technique(std::move(made), {}), params_(std::move(params)) {}

  static Params read(ParamReader& r) { return readDrtv(r); }
  static std::vector<TechniqueInfo> variants() {
    return {{"drtv", "Deferred Radiance Transfer Volumes (GDC 2012): baked probe transfer, relit per frame, a camera volume", {}, &knobs},
            {"drtv-nearest", "DRTV, each volume texel from the probe its index cell names (the talk's fill)", {{"fill", "nearest"}}, {}},
            {"drtv-smooth", "DRTV, each volume texel trilinear over the index cells around it", {{"fill", "smooth"}}, {}}};
  }
  static std::vector<KnobRow> knobs(const KnobContext& c);

 protected:
  Result<void> onPrepare(const PrepareInput& in) override {
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

  Result<void> onPrepareBaked(const Manifest& manifest, std::span<const Sector> sectors) override {
    // An archive's bake is done: its parameters were the bake's (drtv bake), and taking them here
    // would show the archive's light under another bake's name.
    if (!(params_.bake == BakeParams{}))
      return fail("a bake parameter was given (quality, rays_per_basis, bounces, sweeps, covered_spacing, covered_min_h, "
                  "enclosed_spacing, covered_stack, rooms, cache_cells, own_sources, grid_sides, covered_sight, openings, thinning, "
                  "visibility_rays, representation), but this archive is baked already: bake it again with the setting "
                  "(drtv bake), or measure it with drtv accuracy, which bakes each row");
    adopt(manifest, std::vector<Sector>(sectors.begin(), sectors.end()), 0.0);
    return {};
  }

  Result<void> onSetParams(const TechniqueParams& params) override {
    auto p = readParams<Params>(params, &read);
    if (!p) return std::unexpected(p.error());
    if (!(p->bake == params_.bake)) return fail("bake parameters change only with a new prepare");
    const bool lprt_changed = p->runtime.lprt_sources != params_.runtime.lprt_sources;
    params_ = std::move(*p);
    if (lprt_changed) resetSectors();
    rt_.reset();
    return {};
  }

  Result<void> onSetLighting(double hour, const std::vector<PointLight>& lights) override {
    if (!rt_) {
      options_ = runtimeOptions(manifest_.effects);
      // An evaluation reads the lighting of the hour it set: every update publishes its own
      // refill (an engine's blurred refill takes two frames, publish.h; the fly keeps that).
      options_.volume_rebuild_updates = 1;
      const RuntimeParams& p = params_.runtime;
      auto rt = runtime::runtimeForSectors(manifest_, options_, hour, active(), &lights);
      if (!rt) return std::unexpected(rt.error());
      rt_ = std::move(*rt);
      const glm::ivec3 n = options_.volume.size;
      costs_.runtime_bytes = size_t(double(n.x) * n.y * n.z * p.storage_bytes);
      return {};
    }
    if (auto r = rt_->setLights(lights); !r) return std::unexpected(r.error());
    return rt_->setTime(hour);
  }

  Result<void> onUpdate(const glm::dvec3& camera) override {
    rt_->update(camera);
    return {};
  }

  glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const override {
    if (params_.runtime.storage_levels >= 0) return emulated(position, normal);
    return rt_->ambient(position, normal).irradiance;
  }

  std::optional<runtime::RuntimeOptions> onStreamingRuntime(const Manifest& manifest) const override {
    if (params_.runtime.storage_levels >= 0 || params_.runtime.lprt_sources) return std::nullopt;  // emulations
    return runtimeOptions(manifest.effects);
  }

 private:
  // optionsForEffects (what an engine picks for the archive) with this technique's parameters.
  runtime::RuntimeOptions runtimeOptions(uint32_t effects) const {
    runtime::RuntimeOptions o = runtime::optionsForEffects(effects);
    const RuntimeParams& p = params_.runtime;
    o.volume.fill = p.fill;
    o.volume_lookup = p.lookup;
    o.fine.enabled = p.fine;
    if (p.fine_radius) o.fine.radius_m = *p.fine_radius;
    if (p.fine_bias) o.fine.normal_bias_m = *p.fine_bias;
    if (p.fine_min_visibility) o.fine.min_visibility = *p.fine_min_visibility;
    if (p.fine_full_weight) o.fine.full_weight = *p.fine_full_weight;
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
    reportPrepareSeconds(bake_s);
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

  Params params_;
  Manifest manifest_;
  std::vector<Sector> baked_, truncated_;
  runtime::RuntimeOptions options_;
  std::unique_ptr<runtime::Runtime> rt_;
};

std::string fmt(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// DRTV's knobs, one at a time around the defaults (accuracy.h lists them), in the table's order. The
// basis rows and the part probe-reference rows read DRTV's probes with path-traced values (the
// probe-reference technique): what the probes and the index grid alone allow.
// A row's name in the report's table by surface category (KnobRow::by_category): the rows that
// move probes or light indoors, which the categories tell apart, when not the default.
static std::string indoors(const std::string& knob, const std::string& value, bool is_default) {
  return is_default ? std::string() : knob + " " + value;
}

// A bake setting's two rows: `on` (its parameter value `on_value`) and `off`, the default one first
// marked "the default bake: " and baked with no parameter.
static void twoWayRows(std::vector<KnobRow>& rows, const std::string& knob, const std::string& on_value, const std::string& off_value,
                bool on_is_default, const std::string& on_note, const std::string& off_note) {
  for (const bool on : {true, false}) {
    const bool def = on == on_is_default;
    const std::string& value = on ? on_value : off_value;
    rows.push_back({knob, value, def, "drtv", def ? TechniqueParams{} : TechniqueParams{{knob, value}},
                    std::string(def ? "the default bake: " : "") + (on ? on_note : off_note), -1, indoors(knob, value, def)});
  }
}

std::vector<KnobRow> DrtvTechnique::knobs(const KnobContext& c) {
  const baker::BakeSettings& base = c.base;
  const uint32_t effects = c.effects;
  const worlds::World& world = c.world;
  const int probe_samples = c.probe_samples;
  std::vector<KnobRow> rows;
  for (int rays : {32, 64, 128, 256, 512}) {
    const bool def = rays == base.transfer.probe_rays_per_basis;
    rows.push_back({"rays_per_basis", std::to_string(rays), def, "drtv",
                    def ? TechniqueParams{} : TechniqueParams{{"rays_per_basis", std::to_string(rays)}}, def ? "the default bake" : ""});
  }
  for (int bounces : {1, 2, 3, 4}) {
    const bool def = bounces == base.transfer.bounces;
    rows.push_back({"bounces", std::to_string(bounces), def, "drtv",
                    def ? TechniqueParams{} : TechniqueParams{{"bounces", std::to_string(bounces)}}, def ? "the default bake" : ""});
  }
  // Jacobi sweeps over the surface cache (transfer.h): further bounces around its closed links.
  const int default_sweeps = baker::sweepCount(base.transfer);
  for (int sweeps : {default_sweeps, 1, 4, 16, 64}) {
    const bool def = sweeps == default_sweeps;
    if (def && rows.back().knob == "sweeps") continue;  // the default is also one of the others: once
    rows.push_back({"sweeps", std::to_string(sweeps), def, "drtv",
                    def ? TechniqueParams{} : TechniqueParams{{"sweeps", std::to_string(sweeps)}}, def ? "the default bake" : "", -1,
                    indoors("sweeps", std::to_string(sweeps), def)});
  }
  // Probes under roofs (placement.h): the column lattice there / the least distance between them.
  for (const auto& [spacing, min_h] : {std::pair{4.0, 8.0}, std::pair{4.0, 4.0}, std::pair{2.0, 2.0}, std::pair{2.0, 1.4}, std::pair{1.0, 1.0}}) {
    const bool def = spacing == base.placement.covered_column_spacing_m && min_h == base.placement.covered_min_horizontal_m;
    rows.push_back({"placement_under_roofs", fmt(spacing) + " m / " + fmt(min_h) + " m", def, "drtv",
                    def ? TechniqueParams{} : TechniqueParams{{"covered_spacing", fmt(spacing)}, {"covered_min_h", fmt(min_h)}},
                    def ? "the default bake: columns / least distance under roofs" : "columns / least distance under roofs", -1,
                    def ? std::string() : "under roofs " + fmt(spacing) + " m / " + fmt(min_h) + " m"});
  }
  // Probes in enclosed spaces under roofs (placement.h, issue 35): 0 = the covered values.
  for (double e : {2.0, 1.0, 3.0, 0.0}) {
    const bool def = e == base.placement.enclosed_column_spacing_m && e == base.placement.enclosed_min_horizontal_m;
    rows.push_back({"placement_enclosed", e == 0.0 ? std::string("off") : fmt(e) + " m", def, "drtv",
                    def ? TechniqueParams{} : TechniqueParams{{"enclosed_spacing", fmt(e)}},
                    std::string(def ? "the default bake: " : "") +
                        (e == 0.0 ? "as under any roof" : "columns and least distance in rooms and storeys"),
                    -1, indoors("placement_enclosed", e == 0.0 ? std::string("off") : fmt(e) + " m", def)});
  }
  // Probes up tall spaces under roofs (placement.h, issue 35): the default stack against one per floor.
  const double stack = base.placement.covered_stack_m;
  twoWayRows(rows, "covered_stack", fmt(stack > 0.0 ? stack : baker::PlacementSettings{}.covered_stack_m), "0", stack > 0.0,
             "a probe every so many metres up spaces taller than a storey under roofs",
             "one probe per floor under roofs (the builds before 2026-12-07's sixth session)");
  // The visibility maps' rays (visibility_bake.h): the default against the builds before's 4,096.
  rows.push_back({"visibility_rays", std::to_string(base.visibility_rays), true, "drtv", {},
                  "the default bake: rays of a covered probe's visibility map"});
  if (base.visibility_rays != 4096)
    rows.push_back({"visibility_rays", "4096", false, "drtv", {{"visibility_rays", "4096"}}, "the builds before 2026-12-06's second session"});
  // Index cells on their own side of the sky line (index_grid.h, issue 35), against any side.
  twoWayRows(rows, "grid_sides", "same", "any", base.grid.same_side, "cells name probes on their side of the sky line",
             "cells name the nearest visible probe, indoors or out");
  // The least distance only between probes that see each other where one is covered (placement.h).
  twoWayRows(rows, "covered_sight", "on", "off", base.placement.covered_sight,
             "a covered probe keeps others away only where they see each other",
             "the least distance through walls and ceilings (the builds before 2026-12-07)");
  // The visibility maps end at the covered air's openings (visibility_bake.h), against whole rays.
  twoWayRows(rows, "openings", "on", "off", base.visibility_openings, "a covered probe's visibility ends where its rays leave the covered air",
             "covered probes see through windows and doors (the builds before 2026-12-07)");
  // Over the cap, the probes under roofs thinned first (placement.h), against all alike.
  twoWayRows(rows, "thinning", "near-first", "even", base.placement.thin_near_first,
             "a sector over the 255 cap thins its probes under roofs first", "all probes thinned alike (the builds before 2026-12-07)");
  // The default bake of the builds before 2026-12-07's second session, on this run's points: the
  // day's four rules off at once (the old binary would draw other points from its other probes).
  if (base.placement.covered_sight && base.visibility_openings && base.placement.thin_near_first && base.transfer.sweeps != 0)
    rows.push_back({"before", "2026-12-07", false, "drtv",
                    TechniqueParams{{"covered_sight", "off"}, {"openings", "off"}, {"thinning", "even"}, {"sweeps", "1"}},
                    "covered_sight off, openings off, thinning even, 1 sweep: the default bake before 2026-12-07's second session", -1,
                    indoors("before", "2026-12-07", false)});
  // The fine level near surfaces (issue 35), against the volume and the interiors alone.
  rows.push_back({"fine", "on", true, "drtv", {}, "the default: covered probes that see the point, near surfaces"});
  rows.push_back({"fine", "off", false, "drtv", {{"fine", "off"}}, "the volume and the interiors alone", -1, indoors("fine", "off", false)});
  const runtime::FineOptions fine;
  for (float r : {2.5f, 6.f})
    rows.push_back({"fine_radius", fmt(r), false, "drtv", {{"fine_radius", fmt(r)}}, "metres (default " + fmt(fine.radius_m) + ")", -1,
                    indoors("fine_radius", fmt(r), false)});
  for (float w : {0.05f, 1.f})
    rows.push_back({"fine_full_weight", fmt(w), false, "drtv", {{"fine_full_weight", fmt(w)}}, "default " + fmt(fine.full_weight), -1,
                    indoors("fine_full_weight", fmt(w), false)});
  // Closed rooms found at bake time and given interiors (rooms.h), against the artist's alone.
  rows.push_back({"rooms", "auto", base.rooms.enabled, "drtv", base.rooms.enabled ? TechniqueParams{} : TechniqueParams{{"rooms", "auto"}},
                  base.rooms.enabled ? "the default bake: closed rooms get interiors" : "closed rooms get interiors", -1,
                  indoors("rooms", "auto", base.rooms.enabled)});
  rows.push_back({"rooms", "off", !base.rooms.enabled, "drtv", !base.rooms.enabled ? TechniqueParams{} : TechniqueParams{{"rooms", "off"}},
                  "the artist's interiors only", -1, indoors("rooms", "off", !base.rooms.enabled)});
  // Surface cache cells split by the walls that cross them (transfer.h), against shared ones.
  rows.push_back({"cache_cells", "sides", base.transfer.cell_sides, "drtv",
                  base.transfer.cell_sides ? TechniqueParams{} : TechniqueParams{{"cache_cells", "sides"}},
                  base.transfer.cell_sides ? "the default bake: a cell splits where a wall crosses it" : "a cell splits where a wall crosses it",
                  -1, indoors("cache_cells", "sides", base.transfer.cell_sides)});
  rows.push_back({"cache_cells", "shared", !base.transfer.cell_sides, "drtv",
                  !base.transfer.cell_sides ? TechniqueParams{} : TechniqueParams{{"cache_cells", "shared"}}, "one cell per cube and facing", -1,
                  indoors("cache_cells", "shared", !base.transfer.cell_sides)});
  const uint32_t components = runtime::componentsFromEffects(effects);
  const auto& parts = kRuntimeParts;
  for (size_t k = 0; k < parts.size(); ++k)
    if (components & parts[k].second) rows.push_back({"part", parts[k].first, false, "drtv", {{"part", parts[k].first}}, "", int(k)});
  // The same terms baked in fc3 (the talk's bases), so that its bias can be traced to a term too.
  for (size_t k = 0; k < parts.size(); ++k)
    if (components & parts[k].second)
      rows.push_back({"part fc3", parts[k].first, false, "drtv", {{"part", parts[k].first}, {"representation", "fc3"}}, "", int(k)});
  // The sun's SH lobe, fc3's knob: sh-l1 takes its linear lobe and corrects it with the sun
  // transfer (representation.h), which another window would no longer match.
  for (const auto& [name, w] : {std::pair{"hanning", runtime::kHanningBand1}, std::pair{"lanczos", runtime::kLanczosBand1},
                                std::pair{"none", runtime::kNoWindowBand1}})
    rows.push_back({"sun_window fc3", name, false, "drtv", {{"representation", "fc3"}, {"sun_window", name}},
                    "band-1 factor " + fmt(w) + (w == runtime::kHanningBand1 ? ", fc3's own" : "")});
  // The directional representation, each a real bake -> relight -> volume -> ambient
  // (representation.h); sh-l1 (the default) with its own sun (linear lobe and sun transfer) and
  // with fc3's Hanning lobe in place of the linear one.
  rows.push_back({"representation", "sh-l1", true, "drtv", {}, "the default bake: band-1 SH irradiance, fitted sky, traced sun"});
  rows.push_back({"representation", "fc3", false, "drtv", {{"representation", "fc3"}}, "the talk's 4 bases, Hanning sun"});
  rows.push_back({"representation", "sh-l1+hanning", false, "drtv", {{"representation", "sh-l1"}, {"sun_window", "hanning"}},
                  "band-1 SH irradiance, fc3's windowed sun"});
  for (const char* basis : {"4-basis", "ambient-cube", "sh-l1"})
    rows.push_back({"basis", basis, std::string(basis) == "sh-l1", "probe-reference",
                    {{"basis", basis}, {"probe_samples", std::to_string(probe_samples)}}, "path-traced probe values, nearest probe, no volume"});
  // Each term read from path-traced probe values: what the probes and the index grid alone allow
  // that term, beside its `part` row (the bake, the relight and the volume on top).
  for (size_t k = 0; k < parts.size(); ++k)
    if (components & parts[k].second)
      rows.push_back({"part probe-reference", parts[k].first, false, "probe-reference",
                      {{"part", parts[k].first}, {"probe_samples", std::to_string(probe_samples)}},
                      "this term from path-traced probe values (sh-l1), nearest probe, no volume: the probes' floor for it", int(k)});
  rows.push_back({"fill", "nearest", true, "drtv", {{"fill", "nearest"}}, "the default bake"});
  rows.push_back({"fill", "smooth", false, "drtv", {{"fill", "smooth"}}, "trilinear over index-grid cells"});
  rows.push_back({"lookup", "trilinear", true, "drtv", {{"lookup", "trilinear"}}, "the shaders' filter"});
  rows.push_back({"lookup", "facing", false, "drtv", {{"lookup", "facing"}}, "texels behind the surface left out (CPU only)"});
  rows.push_back({"lookup", "sided", false, "drtv", {{"lookup", "sided"}},
                  "texels behind the surface and of the sky line's other side left out (CPU only)"});
  for (float t : {1.f, 2.f, 4.f})
    rows.push_back({"texel_m", fmt(t), glm::vec3(t, t, 2.f * t) == runtime::VolumeOptions{}.texel_size_m, "drtv", {{"texel_m", fmt(t)}},
                    "96x96x16 texels cover +-" + fmt(47.5 * t) + " m"});
  // The volume's precision (sh-l1: e0 unsigned, e1..3 signed about the mid code; snorm8 spends
  // e0's top bit on a sign, as a signed texture format would).
  for (const char* k : {"8-bit", "snorm8", "16-bit", "float"})
    rows.push_back({"storage", k, std::string(k) == "8-bit", "drtv", {{"storage", k}}, "emulated: nearest fill, no blur"});
  // LPRT sources, and how many of them one light is spread onto (probe_cache.h). Their rows give
  // the local-light term's error (as the part rows do): the total hides it under the sky's.
  if ((effects & kEffectLocalLights) && !world.lights.empty()) {
    const runtime::ProbeCacheOptions cache;
    for (int n : {1, 2, 4, 8, 16})
      rows.push_back({"sources_per_light", std::to_string(n), n == cache.sources_per_light, "drtv",
                      {{"part", "local_lights"}, {"sources_per_light", std::to_string(n)}},
                      "local_lights term alone vs the reference's, as a share of the total ambient", reference::kRefLocalLights});
    for (const auto& [name, mode] : {std::pair{"visible", runtime::LightSources::kVisibleFromLight},
                                     std::pair{"nearest", runtime::LightSources::kNearest}})
      rows.push_back({"light_sources", name, mode == cache.light_sources, "drtv", {{"part", "local_lights"}, {"light_sources", name}},
                      mode == runtime::LightSources::kNearest ? "the talk's rule: the nearest source probes"
                                                              : "the probes the index grid names around the light",
                      reference::kRefLocalLights});
    for (const bool own : {true, false})
      rows.push_back({"own_sources local_lights", own ? "on" : "off", own, "drtv",
                      {{"part", "local_lights"}, {"own_sources", own ? "on" : "off"}},
                      own ? "a source where each baked light stands, given that light whole"
                          : "every light shared out over the probes around it, as a moving light",
                      reference::kRefLocalLights, indoors("own_sources local_lights", own ? "on" : "off", own)});
    // The local-light term with the probes under roofs denser (the placement rows above).
    for (const auto& [spacing, min_h] : {std::pair{2.0, 2.0}, std::pair{1.0, 1.0}})
      rows.push_back({"placement_under_roofs local_lights", fmt(spacing) + " m / " + fmt(min_h) + " m", false, "drtv",
                      {{"part", "local_lights"}, {"covered_spacing", fmt(spacing)}, {"covered_min_h", fmt(min_h)}},
                      "local_lights term alone vs the reference's, as a share of the total ambient", reference::kRefLocalLights});
    for (size_t keep : {size_t(8), size_t(32), size_t(64), size_t(kMaxLprtSources)}) {
      const bool all = keep == size_t(kMaxLprtSources);
      TechniqueParams p{{"part", "local_lights"}};
      if (!all) p["lprt_sources"] = std::to_string(keep);
      rows.push_back({"lprt_sources", std::to_string(keep), all, "drtv", p,
                      std::string(all ? "the default bake" : "the first sources of the default bake") +
                          "; local_lights term alone vs the reference's, as a share of the total ambient",
                      reference::kRefLocalLights});
    }
  }
  return rows;
}

}  // namespace

Result<void> registerDrtvTechniques() { return registerTechnique<DrtvTechnique>(); }

}  // namespace drtv::eval
