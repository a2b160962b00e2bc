// drtv/eval/technique.h — one interface for every GI technique drtv compares on the same worlds
// against the same path tracer, in the spirit of pbrt-v4's Integrator and its factory.
//
// A technique is prepared for a world and a block of sectors (baked, or set up), then lit (time
// of day, point lights), then asked for the ambient irradiance at a point with a normal, the way a
// deferred renderer shades a pixel. It reports what that cost: prepare time, update time per
// frame, bytes. Techniques are made by name from a registry, with name=value parameters:
//
//   auto t = makeTechnique("drtv-smooth");                      // a registered variant
//   auto u = makeTechnique("drtv", parseTechniqueParams("fill=smooth,quality=draft").value());
//
// Adding a technique (README, "Layout"): a folder under eval/techniques/ with a class derived from
// Technique (it overrides the protected hooks: onPrepare, onSetLighting, onUpdate, onAmbient) that
// reads its parameters with a ParamReader and declares its variants and knob rows, and one line
// `registerTechnique<YourTechnique>()` (builtinTechniques() in eval/src/technique.cpp, or a test's
// own). It then gets its rows in `drtv accuracy` (knob "technique", and `--knobs <name>`), a
// `--technique` name in `drtv render` and `drtv fly`. tests/technique_toy/ is the smallest one.
//
// Call order, checked by the base (a violation is a bug, DRTV_CHECK): prepare (or prepareBaked)
// before setLighting and beginStreaming; setLighting (or beginStreaming, whose frames carry the
// lighting) before update, ambient and evaluate; setParams after prepare asks for setLighting again. Threading: prepare, setLighting and update from one thread;
// ambient() is const and may run from any number of threads at once between updates.
#pragma once

#include <cstddef>
#include <concepts>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/baker/bake.h"
#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/lighting.h"
#include "drtv/formats/sector.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/runtime/runtime.h"
#include "drtv/streamer/streamer.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {

// Parameters as given: name -> value text ("fill" -> "smooth").
using TechniqueParams = std::map<std::string, std::string>;

// Reads a technique's parameters: each getter names a key the technique takes and, where it is
// given, parses its value into `out` (absent: `out` keeps its default). The first malformed value
// ("texel_m=-1: expected metres in (0, 10000]") and then any key no getter asked for ("unknown
// parameter 'foo' (takes: a, b, c)") are what finish() reports. Messages name the key, not the
// technique: makeTechnique and setParams put "technique <name>: " in front once.
class ParamReader {
 public:
  explicit ParamReader(const TechniqueParams& given) : given_(given) {}

  // An integer in [lo, hi].
  template <std::integral T>
  ParamReader& integer(const std::string& key, T& out, long long lo, long long hi) {
    if (const std::string* v = take(key)) {
      long long x = 0;
      if (!parseWhole(*v, x) || x < lo || x > hi)
        reject(key + "=" + *v + ": expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
      else
        out = T(x);
    }
    return *this;
  }
  template <std::integral T>
  ParamReader& integer(const std::string& key, std::optional<T>& out, long long lo, long long hi) {
    T x{};
    const bool given = given_.count(key) != 0;
    integer(key, x, lo, hi);
    if (given && error_.empty()) out = x;
    return *this;
  }
  // A real number in [lo, hi] (lo_open: (lo, hi]), parsed as T (float or double) directly.
  template <std::floating_point T>
  ParamReader& real(const std::string& key, T& out, double lo, double hi, bool lo_open = false) {
    if (const std::string* v = take(key)) {
      T x{};
      if (!parseReal(*v, x) || !(double(x) <= hi) || double(x) < lo || (lo_open && double(x) == lo))
        reject(key + "=" + *v + ": expected a number in " + (lo_open ? "(" : "[") + number(lo) + ", " + number(hi) + "]");
      else
        out = x;
    }
    return *this;
  }
  template <std::floating_point T>
  ParamReader& real(const std::string& key, std::optional<T>& out, double lo, double hi, bool lo_open = false) {
    T x{};
    const bool given = given_.count(key) != 0;
    real(key, x, lo, hi, lo_open);
    if (given && error_.empty()) out = x;
    return *this;
  }
  // One of a list of names, each standing for a value of T.
  template <class T>
  ParamReader& oneOf(const std::string& key, T& out, std::initializer_list<std::pair<std::string_view, T>> names) {
    if (const std::string* v = take(key)) {
      for (const auto& [name, value] : names)
        if (name == *v) {
          out = value;
          return *this;
        }
      std::string list;
      size_t i = 0;
      for (const auto& [name, value] : names) {
        list += i == 0 ? "" : (i + 1 == names.size() ? " or " : ", ");
        list += name;
        ++i;
      }
      reject(key + "=" + *v + ": expected " + list);
    }
    return *this;
  }
  // "0" or "1".
  ParamReader& flag(const std::string& key, bool& out) { return oneOf(key, out, {{"0", false}, {"1", true}}); }
  // The value text of `key` for a parser of the technique's own (nullptr when not given); the key
  // counts as taken.
  const std::string* text(const std::string& key) { return take(key); }
  // Records a malformed value or combination found by the technique itself (the first one wins).
  void reject(std::string message) {
    if (error_.empty()) error_ = std::move(message);
  }
  bool ok() const { return error_.empty(); }
  // The keys asked for, in order ("a, b, c").
  std::string takes() const;
  // The first error: a malformed value, else a key that no getter asked for.
  Result<void> finish() const;

 private:
  const std::string* take(const std::string& key);
  static bool parseWhole(const std::string& v, long long& x);
  static bool parseReal(const std::string& v, double& x);
  static bool parseReal(const std::string& v, float& x);
  static std::string number(double x);

  const TechniqueParams& given_;
  std::vector<std::string> keys_;
  std::string error_;
};

// Parses `given` with `read` (a technique's `static P read(ParamReader&)`), then finish().
template <class P>
Result<P> readParams(const TechniqueParams& given, P (*read)(ParamReader&)) {
  ParamReader r(given);
  P p = read(r);
  if (auto e = r.finish(); !e) return std::unexpected(e.error());
  return p;
}

// What a technique costs, as measured by the technique itself.
struct TechniqueCosts {
  double prepare_s = 0;       // wall seconds of the last prepare() (a bake, or a set-up)
  double update_ms = 0;       // wall milliseconds of the last update(): a frame's relight and fill
  size_t stored_bytes = 0;    // what prepare() keeps for the runtime (DRTV: encoded sectors)
  size_t runtime_bytes = 0;   // what the runtime adds to shade with (DRTV: the volume textures)
};

// The world and block of sectors to prepare for.
struct PrepareInput {
  const worlds::World& world;
  std::string where;                 // names the world in errors
  raytrace::SectorRange block;       // the sectors, inclusive
  uint64_t seed = 1;
  int threads = 0;                   // 0 = all hardware threads
  // A DRTV bake of this block already made (the accuracy table's default bake). A technique whose
  // own bake would be this one, bit for bit (same settings, same seed), may take it instead of
  // baking again; any other ignores it.
  const baker::InMemoryBake* baked = nullptr;
  // The technique will be streamed (beginStreaming): what it builds per sector for a camera need
  // not be built for the whole block now (the sweep voxelises every sector but sweeps none).
  bool streaming = false;
};

// The DRTV bake of `in`'s block with `settings`: `in.baked` where that is this bake (the same
// settings; its seed is the input's), else one made now with bakeInMemory and kept in `own`.
// Errors: bakeInMemory's.
Result<const baker::InMemoryBake*> bakeFor(const PrepareInput& in, const baker::BakeSettings& settings,
                                           std::optional<baker::InMemoryBake>& own);

// How a streamed technique is set up (beginStreaming): the archive the streamer streams and the
// volume's reach, and where its per-sector work runs.
struct StreamingSetup {
  const Manifest& manifest;               // the streamer's archive (which sectors exist)
  streamer::ResidencyOptions residency;   // the streamer's: the volume's footprint is the reach
  double start_hour = 12.0;               // the time of day of the first frame
  bool deterministic = true;              // per-sector jobs simulated in camera time (as the
                                          // streamer's kDeterministic I/O), else worker threads
};

// One frame of a streamed technique.
struct StreamingFrame {
  double frame_ms = 0.0;      // the frame thread's time in frame(), less inline_ms
  double inline_ms = 0.0;     // deterministic: the per-sector jobs run inline (a worker's time)
  int reach = 0;              // sectors within the volume's footprint that get per-sector state
  int missing = 0;            // of those, sectors without it (lookups fall back to coarser state)
  int held = 0;               // sectors holding per-sector state
  int stale = 0;              // of them, built for an older lighting than the current
  int queued = 0;             // per-sector jobs waiting or running
  size_t bytes = 0;           // the technique's runtime state
  bool idle = false;          // nothing left to build for this camera and hour
};

// A streamed technique's per-frame side. The streamer's sink calls (SectorSink) tell it which
// sectors are resident; frame() is called once per frame after the streamer's update.
class TechniqueStream : public streamer::SectorSink {
 public:
  // The camera (position and velocity: the look-ahead), the camera clock (non-decreasing), the
  // time of day and the lights. Errors end a flight.
  virtual Result<StreamingFrame> frame(const streamer::Camera& camera, double time_s, double hour,
                                       const std::vector<PointLight>& lights) = 0;
};

// What a flight (`drtv fly --technique`) calls for a technique that runs on its own (no
// streamingRuntime): the streamer's loads and evictions go to `sink` (null: the technique does not
// stream per sector), and `frame` runs once per frame after the streamer's update. A frame of a
// technique that does not stream reports reach -1, its update as frame_ms, and idle.
struct TechniqueFlight {
  streamer::SectorSink* sink = nullptr;
  std::function<Result<StreamingFrame>(const streamer::Camera& camera, double time_s, double hour,
                                       const std::vector<PointLight>& lights)>
      frame;
  size_t bytes = 0;  // what it holds when the flight starts
};

// A point to shade: world metres and a unit normal.
struct SurfacePoint {
  glm::dvec3 position{0.0};
  glm::vec3 normal{0.f, 0.f, 1.f};
};

// Where a technique's per-frame work happens, which the base times into TechniqueCosts::update_ms.
enum class FrameWork {
  kUpdate,    // update() (relight and fill for the camera)
  kLighting,  // setLighting() (the sweep sweeps for the hour; update does nothing)
  kNone,      // nothing runs per frame (update_ms is NaN)
};

// What callers need to know of a technique to drive it (render, fly): one description, set by the
// technique at construction, never a per-technique branch in a caller.
struct TechniqueTraits {
  // prepare() from the world even where a baked archive exists (the sweep and LPV voxelise or ray
  // cast the world's triangles and bake nothing); else prepareBaked() reads an archive.
  bool prepares_from_world = false;
  // beginStreaming() is supported (after prepare with PrepareInput::streaming).
  bool streams_per_sector = false;
  FrameWork frame_work = FrameWork::kUpdate;
};

// The name a technique was made under and the parameters it was given (describe()).
struct TechniqueMade {
  std::string name;
  TechniqueParams given;
};

// A GI technique. Callers use the public non-virtual interface, which checks the call order (a
// violation is a bug: DRTV_CHECK aborts), rejects non-finite hours and cameras (input errors),
// times prepare and the frame's work into costs() and names the technique in errors. Techniques
// override the protected hooks.
class Technique {
 public:
  virtual ~Technique() = default;
  Technique(const Technique&) = delete;
  Technique& operator=(const Technique&) = delete;

  // Bakes or sets up for `input`'s block. Errors: the world's (bad lighting, no geometry).
  Result<void> prepare(const PrepareInput& input);
  // Prepares from what a bake already wrote (an archive's manifest and sectors). Techniques that
  // do not bake into drtv archives return an error naming themselves.
  Result<void> prepareBaked(const Manifest& manifest, std::span<const Sector> sectors);
  // The preparation a viewer of a baked archive wants: prepareBaked() from the archive's sectors,
  // or prepare() from `world` for a technique that prepares from the world (traits()).
  Result<void> prepareForArchive(const Manifest& manifest, std::span<const Sector> sectors, const PrepareInput& world);
  // The lighting: the prepared world's sky at `hour` (any finite real, modulo 24) and `lights`.
  Result<void> setLighting(double hour, const std::vector<PointLight>& lights);
  // Brings the technique's state up to date for a camera at `camera` (world metres, finite).
  Result<void> update(const glm::dvec3& camera);
  // Ambient irradiance (linear RGB, W/m^2-like units of the sky) at world `position` on a surface
  // with unit normal `normal`.
  glm::vec3 ambient(const glm::dvec3& position, const glm::vec3& normal) const {
    DRTV_CHECK_LE(int(Stage::kLit), int(stage_));
    return onAmbient(position, normal);
  }
  // The ambient at each of `points`, shaded as a frame's pixels are: by default update() with the
  // camera at each point in turn, then ambient(). A technique that needs to see the points first
  // (the path-traced probe values of `probe-reference`) overrides onEvaluate.
  Result<std::vector<glm::vec3>> evaluate(std::span<const SurfacePoint> points);
  // Changes parameters (after prepare: without preparing again; setLighting is due again). A
  // parameter that needs another prepare (DRTV: quality, rays_per_basis, bounces) with a value
  // other than the prepared one is an error, and so is an unknown one; nothing changes then.
  Result<void> setParams(const TechniqueParams& params);
  // What it cost: prepare and the frame's work timed here, bytes as the technique reports them.
  const TechniqueCosts& costs() const { return costs_; }
  // The drtv::runtime configuration an engine streaming `manifest`'s archive runs this technique
  // with (`drtv fly --technique`: the streamer loads sectors into a runtime set up so, and its
  // residency holds what that volume covers); nothing for a technique that does not run on
  // drtv::runtime.
  std::optional<runtime::RuntimeOptions> streamingRuntime(const Manifest& manifest) const { return onStreamingRuntime(manifest); }
  // Streams a technique that runs on its own (traits().streams_per_sector): after prepare() with
  // PrepareInput::streaming, it builds its per-sector state as the streamer brings sectors in and
  // ambient() reads the finest state it holds. The stream is the technique's (valid while it
  // lives; a second call replaces it). Errors name the technique.
  Result<TechniqueStream*> beginStreaming(const StreamingSetup& setup);
  // Sets up a flight over `setup.manifest`'s archive for a technique that runs on its own: prepare()
  // from `world` for the block of the archive's sectors (streaming when it streams per sector),
  // then beginStreaming or, per frame, setLighting and update. The flight calls must not outlive
  // the technique.
  Result<TechniqueFlight> prepareFlight(const worlds::World& world, const std::string& where, const StreamingSetup& setup);
  const TechniqueTraits& traits() const { return traits_; }
  // The registered name it was made under, and its parameters as text ("drtv fill=smooth").
  std::string describe() const;

 protected:
  Technique(TechniqueMade made, TechniqueTraits traits) : made_(std::move(made)), traits_(traits) {}

  virtual Result<void> onPrepare(const PrepareInput& input) = 0;
  virtual Result<void> onPrepareBaked(const Manifest& manifest, std::span<const Sector> sectors);  // default: an error
  virtual Result<void> onSetLighting(double hour, const std::vector<PointLight>& lights) = 0;
  virtual Result<void> onUpdate(const glm::dvec3& camera) = 0;
  virtual glm::vec3 onAmbient(const glm::dvec3& position, const glm::vec3& normal) const = 0;
  virtual Result<std::vector<glm::vec3>> onEvaluate(std::span<const SurfacePoint> points);  // default: above
  virtual Result<void> onSetParams(const TechniqueParams& params);  // default: takes none
  virtual std::optional<runtime::RuntimeOptions> onStreamingRuntime(const Manifest&) const { return std::nullopt; }
  virtual Result<TechniqueStream*> onBeginStreaming(const StreamingSetup& setup);  // default: an error

  // A prepare that adopts a bake made elsewhere reports that bake's seconds (else the base times it).
  void reportPrepareSeconds(double s) {
    costs_.prepare_s = s;
    prepare_reported_ = true;
  }
  void setTraits(const TechniqueTraits& traits) { traits_ = traits; }
  // Bytes (stored_bytes, runtime_bytes) are the technique's to keep up to date; prepare_s and
  // update_ms are the base's (above).
  TechniqueCosts costs_;

 private:
  enum class Stage { kNew, kPrepared, kLit };
  Result<void> prepared(Result<void> r);

  TechniqueMade made_;
  TechniqueTraits traits_;
  Stage stage_ = Stage::kNew;
  bool prepare_reported_ = false;
};

// Parses "name=value,name=value" ("" gives none). Errors name the piece: "'fill': expected name=value".
Result<TechniqueParams> parseTechniqueParams(std::string_view text);

// One row of `drtv accuracy`'s table: a technique with parameters, compared with the whole
// reference ambient (part < 0) or with one of its terms (a reference::ReferencePart).
struct KnobRow {
  std::string knob, value;
  bool is_default = false;
  std::string technique;
  TechniqueParams params;
  std::string note;
  int part = -1;
  // The row's name in the report's table by surface category (rows that move probes or light
  // indoors, which the categories tell apart); "" = not in that table.
  std::string by_category = {};
};

// What a technique's knob rows depend on: the accuracy table's default bake and world.
struct KnobContext {
  const baker::BakeSettings& base;  // the default bake's settings
  uint32_t effects = 0;             // the default bake's effects (kEffect*)
  const worlds::World& world;
  int probe_samples = 256;          // AccuracyOptions::probe_samples
};
using KnobRows = std::function<std::vector<KnobRow>(const KnobContext&)>;

// Rows of one knob moved one value at a time around its default (the default row with no
// parameters): knob `knob`, parameter `param`, for technique `technique`.
std::vector<KnobRow> knobAround(const std::string& technique, const std::string& knob, const std::string& param,
                                const std::vector<std::string>& values, const std::string& default_value, const std::string& note);

struct TechniqueInfo {
  std::string name;
  std::string description;
  TechniqueParams preset;  // parameters the name stands for (a variant); given ones override them
  KnobRows knobs;          // the technique's knob rows (`drtv accuracy --knobs <name>`); may be empty
};
using TechniqueFactory = std::function<Result<std::unique_ptr<Technique>>(const TechniqueMade&)>;

// Registers `info.name` (a name already taken is an error). Thread-safe.
Result<void> registerTechnique(TechniqueInfo info, TechniqueFactory factory);

// Registers a technique type T under each of its variants. T declares:
//   static std::vector<TechniqueInfo> variants();   // name, description, preset; the first one's
//                                                   // `knobs` are the technique's knob rows
//   struct Params; static Params read(ParamReader&); // its parameters, read (defaults: Params{})
//   T(TechniqueMade made, Params params);
template <class T>
Result<void> registerTechnique() {
  for (TechniqueInfo info : T::variants()) {
    auto factory = [](const TechniqueMade& made) -> Result<std::unique_ptr<Technique>> {
      auto p = readParams<typename T::Params>(made.given, &T::read);
      if (!p) return std::unexpected(p.error());
      return std::unique_ptr<Technique>(new T(made, std::move(*p)));
    };
    if (auto r = registerTechnique(std::move(info), factory); !r) return r;
  }
  return {};
}

// Every registered technique, in registration order (the built-in ones first).
std::vector<TechniqueInfo> registeredTechniques();
// Their names, comma-separated ("drtv, drtv-nearest, ..."), for help texts and errors.
std::string registeredTechniqueNames();
// Makes the technique `name` with its preset overridden by `params`. Errors: an unknown name
// (listing the known ones), a parameter the technique does not take or a bad value, each once
// prefixed "technique <name>: ".
Result<std::unique_ptr<Technique>> makeTechnique(std::string_view name, const TechniqueParams& params = {});

}  // namespace drtv::eval
