// drtv/runtime/runtime.h — the engine-facing object: lighting in, resident sectors in, camera in,
// published volumes and ambient(position, normal) out.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012: slides 25-32
//      (relighting when the lighting changes), 33-36 (volumes), 40-44 (ambient), 54 (closest probe
//      for transparencies), 55-56 (interior volumes), 57-58 (distant ambient), 60 (blur).
//
// What is recomputed when (DESIGN.md "relight only what changed"):
//  - setTime/setLighting evaluate the sun and sky; update() relights every resident probe only
//    when the lighting moved more than `relight_threshold` since the last relight
//    (lightingChange, lighting_sh.h), or setLighting changed the sky description. A full relight
//    repacks all probes with a new HDR scale (max colour x `hdr_headroom`) and refills the volumes.
//  - setLights alone (lights moved, appeared, dimmed): update() relights only the sectors whose
//    LPRT sources the lights' old or new shares land on (ProbeCache::relightChangedLights), packs
//    those and refills their footprints. The packed HDR scale is kept unless a relit sector
//    exceeds it or the scale a full relight would choose fell below half of it; then everything is
//    repacked and refilled. The colours equal a full relight's bit for bit either way. A sector
//    streaming in or leaving with lights set also runs this at the next update() (it moves shares).
//  - addSector relights that sector alone with the lighting last applied and refills its
//    footprint; only if its colours exceed the HDR scale is everything repacked and refilled.
//    With local lights set it is relit at the next update() instead, with the lights' shares
//    redistributed once for it and its neighbours (above); its colours are black until then.
//  - update(camera) scrolls the volumes: only slabs that entered are computed. A blurred full
//    refill is spread over `volume_rebuild_updates` updates (publish.h).
//
// Ambient at a point (ambient()):
//   volume  = sampleVolume at the point (the talk's shader), weight = Volume::coverage with
//             `edge_fade_texels` (1 inside, fading to 0 at the volume's edge);
//   distant = distantAmbient (sky irradiance x top-down occlusion, occlusion.h);
//   a       = mix(distant, volume, weight);
//   interior: inside an artist InteriorVolume with a resolved designated probe, the probe's own
//             colours shaded for the normal (shade(): the shading weights, or sh-l1's E(n)); blended in over blend_distance_m from the
//             box faces inward: result = mix(a, interior, saturate(depth / blend_distance_m)).
//   fine:     where covered probes see the point (ProbeCache::fineLookup), their weighted colours
//             shaded for the normal: result = mix(result, fine, fine weight).
//
// Thread-safety: one writer thread calls the non-const members. ambient(), nearestProbe() and the
// other const members must not run concurrently with the writer, except volume().read(), which
// any thread may use at any time (publish.h).
#pragma once

#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/effects.h"
#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/formats/sector.h"
#include "drtv/runtime/fine_shader.h"
#include "drtv/runtime/lighting_sh.h"
#include "drtv/runtime/occlusion.h"
#include "drtv/runtime/probe_cache.h"
#include "drtv/runtime/publish.h"
#include "drtv/runtime/volume.h"

namespace drtv::runtime {

// The normal as ambient() reads it: `n` made unit length (a huge finite one rescaled first, so
// that its squared length cannot overflow), +Z when it has no direction (zero, NaN, infinite).
glm::vec3 ambientNormal(const glm::vec3& n);

inline constexpr float kSunLobeOfRepresentation = -1.f;  // RuntimeOptions::sun_band1_window

// The relighting components a world's effect mask asks for (effects.h -> probe_cache.h).
uint32_t componentsFromEffects(uint32_t effects);

struct RuntimeOptions {
  // The archive's directional representation (representation.h); the Runtime copies it into
  // `cache` and `volume` (theirs are ignored). runtimeForArchive sets it from the manifest.
  Representation representation = Representation::kFc3;
  VolumeOptions volume;                       // size, texel size, fill mode, blur
  ProbeCacheOptions cache;                    // resident slots, sources per light
  // The sun's SH lobe (lighting_sh.h). kSunLobeOfRepresentation: the representation's own, set by
  // the Runtime: fc3 the Hanning window (band 0 x 1, band 1 x 1/2: why, lighting_sh.h), sh-l1 the
  // linear sun (band 0 x 0, band 1 x 2: the plane cases and scenes, docs/accuracy.md "Sun").
  // Any other value is used as given, with sun_band0_scale.
  float sun_band1_window = kSunLobeOfRepresentation;
  float sun_band0_scale = 1.f;
  uint32_t components = kAllComponents;       // relighting terms evaluated
  uint32_t effects = kAllEffects;             // interiors and distant occlusion are honoured here
  // Relight when lightingChange exceeds this: 1/512 is half an 8-bit step of the brightest light,
  // below what the RGBA8 volume can show.
  float relight_threshold = 1.f / 512.f;
  // HDR scale = max relit colour x this, so that a sector streaming in rarely exceeds it (which
  // would force a full repack and refill); costs log2(1.25) = 0.3 bit of the 8.
  float hdr_headroom = 1.25f;
  // The talk's OffsetLength [1, slide 40]: the sample moves this far along the normal so that a
  // surface reads the texel in front of it rather than the one behind; half a 2 m texel.
  float normal_offset_m = 1.f;
  // Volume lookups fade to distant ambient over this many texels before the volume's edge.
  float edge_fade_texels = 2.f;
  // How ambient() reads the volume: the talk's trilinear filter (what the shaders do), or with
  // the texels behind the surface left out (sampleVolumeFacing), or those behind it and of the
  // other side of the sky line (sampleVolumeSided); the last two the CPU only, for evaluation.
  enum class VolumeLookup { kTrilinear, kFacing, kSided } volume_lookup = VolumeLookup::kTrilinear;
  // A relight's blurred full refill is spread over this many updates (publish.h): each frame
  // does half the fill and blur, and the volume shows a time-of-day change one frame late. 1:
  // every update publishes its own lighting. Without blur a refill always takes one update. >= 1.
  int volume_rebuild_updates = 2;
  // The fine level near surfaces (ProbeCache::fineLookup): blended over everything above by its
  // weight. It reads only probes flagged kProbeCovered, so a world without any is unchanged.
  FineOptions fine;
  // Set: update() also packs the fine level for the shaders around the camera (packFineLevel,
  // fine_shader.h; its lookup is `fine`), which fineLevel() hands out, whenever the box's corner,
  // the probes' colours or the resident sectors changed since the last pack. On an UpdateWorker
  // the packing is the worker's, off the frame's critical path.
  std::optional<FineShaderOptions> fine_shader;
};

// The options an engine picks for an archive whose manifest says `effects` were baked: the
// relighting components it has, interiors and distant occlusion as baked, the volume blur (the
// talk's PC path) when the world asks for it; everything else at its default.
RuntimeOptions optionsForEffects(uint32_t effects);

// Which path produced the ambient at a point, with its parts.
struct AmbientSample {
  glm::vec3 irradiance{0.f};      // the final ambient irradiance, linear RGB
  float volume_weight = 0.f;      // coverage of the volume (0 = distant ambient only)
  float interior_weight = 0.f;    // 0 outside every interior
  int interior = -1;              // index into the interiors, or -1
  glm::vec3 volume{0.f};          // the volume lookup (meaningful when volume_weight > 0)
  glm::vec3 distant{0.f};         // the distant ambient
  glm::vec3 interior_ambient{0.f};
  float fine_weight = 0.f;        // the fine level's weight (0: none)
  glm::vec3 fine{0.f};            // the fine level's ambient (meaningful when fine_weight > 0)
};

class Runtime {
 public:
  explicit Runtime(RuntimeOptions options = {});

  // Sets the sun path, sky gradients, dynamic lights and interior volumes. Errors (nothing
  // changes): validateLighting's message, e.g. "sky.sky_zenith[1].value: colour must be in [0, 1e+09]".
  Result<void> setLighting(const Sky& sky, std::vector<PointLight> lights, std::vector<InteriorVolume> interiors);
  // Sets the time of day in hours (any finite real, modulo 24). Error if not finite.
  Result<void> setTime(double hour);
  Result<void> setLights(std::vector<PointLight> lights);

  // Makes `sector` resident: relit with the lighting last applied, its occlusion tile built, its
  // footprint refilled at the next update(). Errors as ProbeCache::addSector.
  // `tile`: the sector's occlusion tile when the caller built it already (the streamer does, on
  // its I/O thread); otherwise, with distant occlusion asked for, it is built here. `block`: as
  // ProbeCache::addSector (a SectorSink of the streamer may pass kBorrow).
  Result<void> addSector(const Sector& sector, const OcclusionTile* tile = nullptr, SectorBlock block = SectorBlock::kCopy);
  bool removeSector(SectorKey key);

  // Relights if needed, moves the volumes to `camera` (world metres) and publishes.
  void update(const glm::dvec3& camera);

  // Ambient irradiance at world `position` for surface `normal` (normalised here; a zero or
  // non-finite normal reads as +Z). Finite for finite input. See the header for the blend.
  AmbientSample ambient(const glm::dvec3& position, const glm::vec3& normal) const;
  // The colours of the probe the index grid names at `position` (transparencies, slide 54).
  std::optional<BasisColours> nearestProbeColours(const glm::dvec3& position) const;

  const RuntimeOptions& options() const { return options_; }
  const SkyLighting& lighting() const { return current_; }
  const ProbeCache& cache() const { return cache_; }
  const PublishedVolume& volume() const { return volume_; }
  // The fine level the last update() packed (RuntimeOptions::fine_shader), whole: a reader keeps
  // the one it took while the next update packs another. Null before the first update or without
  // the option.
  std::shared_ptr<const FineShaderData> fineLevel() const {
    std::lock_guard lock(fine_mutex_);
    return fine_level_;
  }
  const OcclusionMap& occlusion() const { return occlusion_; }
  const std::vector<InteriorVolume>& interiors() const { return interiors_; }
  // The designated probe of interior k, if one is resident.
  ProbeRef interiorProbe(size_t k) const { return k < interior_probes_.size() ? interior_probes_[k] : ProbeRef{}; }
  // Full relights done so far (for tests of "relight only what changed").
  uint64_t relightCount() const { return relights_; }
  // Updates that relit only the sectors changed lights reach (at least one sector relit), and
  // how many of those fell back to repacking and refilling everything (the HDR scale).
  uint64_t lightRelightCount() const { return light_relights_; }
  uint64_t lightRescaleCount() const { return light_rescales_; }

 private:
  RelightInput relightInput() const;
  float hdrScale() const;  // the scale rescale() packs with: max colour (and fallback) x headroom
  void rescale();
  void relightMovedLights();
  // Resolves the designated probes of the interiors a sector's arrival or departure can change
  // (those whose box, or designated position, lies over it); every interior when `key` is unset.
  void resolveInteriors(std::optional<SectorKey> key = std::nullopt);
  // The interiors whose box (grown by the surface slack) or designated position lies over a
  // sector, by sector: a town's 18,756 rooms cost each load a scan of all of them, 36 ms a frame.
  static uint64_t packKey(SectorKey k) { return (uint64_t(uint32_t(k.ix)) << 32) | uint32_t(k.iy); }
  const std::vector<uint32_t>* interiorsOver(SectorKey key) const;

  RuntimeOptions options_;
  Sky sky_ = Sky::tropicalDefault();
  std::vector<PointLight> lights_;
  std::vector<InteriorVolume> interiors_;
  std::vector<ProbeRef> interior_probes_;
  std::unordered_map<uint64_t, std::vector<uint32_t>> interiors_by_sector_;
  double hour_ = 12.0;
  SkyLighting current_, applied_;
  bool relit_once_ = false, sky_changed_ = false, lights_changed_ = false;
  ProbeCache cache_;
  PublishedVolume volume_;
  mutable std::mutex fine_mutex_;  // guards fine_level_ (the pointer, not the level: that is never written once published)
  std::shared_ptr<const FineShaderData> fine_level_;
  bool fine_stale_ = true;  // colours or resident sectors changed since fine_level_ was packed
  glm::dvec3 fine_corner_{0.0};  // fineBoxCorner of fine_level_
  OcclusionMap occlusion_;
  uint64_t relights_ = 0, light_relights_ = 0, light_rescales_ = 0;
};

// The one way a runtime is set up from an archive (the engine's, `drtv query`'s, the fly-through's,
// the evaluation's): `options` (optionsForEffects(manifest.effects) for what an engine picks) with
// the manifest's representation, lit
// by the manifest's sky, its lights (or `lights` instead when given) and its interiors at `hour`.
// The caller then adds the sectors it holds. Errors: unsound lighting, a non-finite hour.
Result<std::unique_ptr<Runtime>> runtimeForArchive(const Manifest& manifest, const RuntimeOptions& options, double hour,
                                                   const std::vector<PointLight>* lights = nullptr);

// runtimeForArchive holding `sectors`, each added in order (copied), its cache grown to hold them
// all when options.cache.max_sectors is smaller: what a tool that holds a fixed set of sectors
// without streaming sets up (drtv query, the preview renders, the techniques of the accuracy
// table, the OpenVDB export). Errors: runtimeForArchive's, and a sector the cache refuses
// (ProbeCache::addSector), prefixed "sector (x,y): ".
Result<std::unique_ptr<Runtime>> runtimeForSectors(const Manifest& manifest, const RuntimeOptions& options, double hour,
                                                   std::span<const Sector> sectors,
                                                   const std::vector<PointLight>* lights = nullptr);

}  // namespace drtv::runtime
