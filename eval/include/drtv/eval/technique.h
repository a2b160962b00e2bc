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
// Adding a technique (README, "Layout"): a folder under eval/techniques/ with its class and a
// register function, one line in builtinTechniques() (eval/src/technique.cpp), and it gets its rows
// in `drtv accuracy` (knob "technique") and a `--technique` name in `drtv render`.
//
// Threading: prepare, setLighting and update from one thread; ambient() is const and may run from
// any number of threads at once between updates.
#pragma once

#include <cstddef>
#include <functional>
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

using TechniqueParams = std::map<std::string, std::string>;

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

// A point to shade: world metres and a unit normal.
struct SurfacePoint {
  glm::dvec3 position{0.0};
  glm::vec3 normal{0.f, 0.f, 1.f};
};

class Technique {
 public:
  virtual ~Technique() = default;
  // Bakes or sets up for `input`'s block. Errors: the world's (bad lighting, no geometry).
  virtual Result<void> prepare(const PrepareInput& input) = 0;
  // Prepares from what a bake already wrote (an archive's manifest and sectors). Techniques that
  // do not bake into drtv archives return an error naming themselves (the default).
  virtual Result<void> prepareBaked(const Manifest& manifest, std::span<const Sector> sectors);
  // Whether the technique is prepared from the world even where a baked archive exists (the sweep
  // voxelises the world's triangles and bakes nothing): `drtv render` then calls prepare() for
  // the block a streamer would hold around the camera instead of prepareBaked(). Default: false.
  virtual bool preparesFromWorld() const { return false; }
  // The lighting: the prepared world's sky at `hour` (any finite real, modulo 24) and `lights`.
  virtual Result<void> setLighting(double hour, const std::vector<PointLight>& lights) = 0;
  // Brings the technique's state up to date for a camera at `camera` (world metres).
  virtual Result<void> update(const glm::dvec3& camera) = 0;
  // Ambient irradiance (linear RGB, W/m^2-like units of the sky) at world `position` on a surface
  // with unit normal `normal`.
  virtual glm::vec3 ambient(const glm::dvec3& position, const glm::vec3& normal) const = 0;
  // The ambient at each of `points`, shaded as a frame's pixels are: by default update() with the
  // camera at each point in turn, then ambient(). A technique that needs to see the points first
  // (the path-traced probe values of `probe-reference`) overrides it.
  virtual Result<std::vector<glm::vec3>> evaluate(std::span<const SurfacePoint> points);
  // Changes parameters after prepare() without preparing again. A parameter that needs another
  // prepare (DRTV: quality, rays_per_basis, bounces) with a value other than the prepared one is
  // an error, and so is an unknown one; nothing changes then. Default: takes none.
  virtual Result<void> setParams(const TechniqueParams& params);
  virtual TechniqueCosts costs() const = 0;
  // The drtv::runtime configuration an engine streaming `manifest`'s archive runs this technique
  // with (`drtv fly --technique`: the streamer loads sectors into a runtime set up so, and its
  // residency holds what that volume covers); nothing for a technique that does not run on
  // drtv::runtime (the default).
  virtual std::optional<runtime::RuntimeOptions> streamingRuntime(const Manifest& manifest) const;
  // Streams a technique that runs on its own (no streamingRuntime): after prepare() with
  // PrepareInput::streaming, it builds its per-sector state as the streamer brings sectors in and
  // ambient() reads the finest state it holds. The stream is the technique's (valid while it
  // lives; a second call replaces it). Default: an error naming the technique.
  virtual Result<TechniqueStream*> beginStreaming(const StreamingSetup& setup);
  // Whether beginStreaming is supported (default: false).
  virtual bool streamsPerSector() const { return false; }
  // The registered name it was made under, and its parameters as text ("fill=smooth").
  virtual std::string describe() const = 0;
};

// Parses "name=value,name=value" ("" gives none). Errors name the piece: "'fill': expected name=value".
Result<TechniqueParams> parseTechniqueParams(std::string_view text);

struct TechniqueInfo {
  std::string name;
  std::string description;
  TechniqueParams preset;  // parameters the name stands for (a variant); given ones override them
};
using TechniqueFactory = std::function<Result<std::unique_ptr<Technique>>(const TechniqueParams&)>;

// Registers `info.name` (a name already taken is an error). Thread-safe.
Result<void> registerTechnique(TechniqueInfo info, TechniqueFactory factory);
// Every registered technique, in registration order (the built-in ones first).
std::vector<TechniqueInfo> registeredTechniques();
// Their names, comma-separated ("drtv, drtv-nearest, ..."), for help texts and errors.
std::string registeredTechniqueNames();
// Makes the technique `name` with its preset overridden by `params`. Errors: an unknown name
// (listing the known ones), a parameter the technique does not take or a bad value.
Result<std::unique_ptr<Technique>> makeTechnique(std::string_view name, const TechniqueParams& params = {});

}  // namespace drtv::eval
