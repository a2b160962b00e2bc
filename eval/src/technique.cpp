// The technique registry (technique.h).
#include "drtv/eval/technique.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <sstream>

#include "techniques.h"

namespace drtv::eval {
namespace {

using Clock = std::chrono::steady_clock;

struct Entry {
  TechniqueInfo info;
  TechniqueFactory factory;
};

struct Registry {
  std::mutex mutex;
  std::vector<Entry> entries;
};

Result<void> add(Registry& r, TechniqueInfo info, TechniqueFactory factory) {
  for (const Entry& e : r.entries)
    if (e.info.name == info.name) return fail("technique '" + info.name + "' is registered already");
  if (info.name.empty() || !factory) return fail("a technique needs a name and a factory");
  r.entries.push_back({std::move(info), std::move(factory)});
  return {};
}

// The built-in techniques, registered explicitly on first use (a static library drops object
// files nothing references, so self-registering globals would silently vanish).
// They call registerTechnique<T>() (technique.h), which takes the lock: the registry is made
// first, then filled once.
Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}

// Set while this thread registers the built-in ones (their registerTechnique calls must not wait
// for themselves).
thread_local bool filling_builtins = false;

void builtinTechniques() {
  static std::once_flag once;
  if (filling_builtins) return;
  std::call_once(once, [] {
    filling_builtins = true;
    (void)registerDrtvTechniques();
    (void)registerProbeReferenceTechnique();
    (void)registerLpvTechnique();
    (void)registerSweepTechniques();
    (void)registerAmbientCubeTechnique();
    filling_builtins = false;
  });
}

Registry& filledRegistry() {
  builtinTechniques();
  return registry();
}

}  // namespace

// --- ParamReader ---

const std::string* ParamReader::take(const std::string& key) {
  if (std::find(keys_.begin(), keys_.end(), key) == keys_.end()) keys_.push_back(key);
  const auto it = given_.find(key);
  return it == given_.end() ? nullptr : &it->second;
}

bool ParamReader::parseWhole(const std::string& v, long long& x) {
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  return ec == std::errc() && end == v.data() + v.size();
}

bool ParamReader::parseReal(const std::string& v, double& x) {
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  return ec == std::errc() && end == v.data() + v.size() && std::isfinite(x);
}

bool ParamReader::parseReal(const std::string& v, float& x) {
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  return ec == std::errc() && end == v.data() + v.size() && std::isfinite(x);
}

std::string ParamReader::number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

std::string ParamReader::takes() const {
  std::string out;
  for (const std::string& k : keys_) out += (out.empty() ? "" : ", ") + k;
  return out;
}

Result<void> ParamReader::finish() const {
  if (!error_.empty()) return fail(error_);
  for (const auto& [k, v] : given_)
    if (std::find(keys_.begin(), keys_.end(), k) == keys_.end())
      return fail("unknown parameter '" + k + "' (takes: " + (keys_.empty() ? std::string("none") : takes()) + ")");
  return {};
}

// --- Technique: the call order, the timing, the names in errors ---

namespace {
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
}  // namespace

std::string Technique::describe() const {
  std::string s = made_.name;
  char sep = ' ';
  for (const auto& [k, v] : made_.given) s += sep + k + "=" + v, sep = ',';
  return s;
}

Result<const baker::InMemoryBake*> bakeFor(const PrepareInput& in, const baker::BakeSettings& settings,
                                           std::optional<baker::InMemoryBake>& own) {
  if (in.baked && in.baked->manifest.settings == settings.describe()) return in.baked;
  auto b = baker::bakeInMemory(in.world, in.where, settings, in.block, in.threads);
  if (!b) return std::unexpected(b.error());
  own = std::move(*b);
  return &*own;
}

Result<void> Technique::prepared(Result<void> r) {
  if (!r) {
    stage_ = Stage::kNew;
    return r;
  }
  stage_ = Stage::kPrepared;
  return {};
}

Result<void> Technique::prepare(const PrepareInput& input) {
  const auto t0 = Clock::now();
  prepare_reported_ = false;
  auto r = onPrepare(input);
  if (r && !prepare_reported_) costs_.prepare_s = msSince(t0) / 1e3;
  return prepared(std::move(r));
}

Result<void> Technique::prepareBaked(const Manifest& manifest, std::span<const Sector> sectors) {
  const auto t0 = Clock::now();
  prepare_reported_ = false;
  auto r = onPrepareBaked(manifest, sectors);
  if (r && !prepare_reported_) costs_.prepare_s = msSince(t0) / 1e3;
  return prepared(std::move(r));
}

Result<void> Technique::prepareForArchive(const Manifest& manifest, std::span<const Sector> sectors, const PrepareInput& world) {
  return traits_.prepares_from_world ? prepare(world) : prepareBaked(manifest, sectors);
}

Result<void> Technique::setLighting(double hour, const std::vector<PointLight>& lights) {
  DRTV_CHECK_LE(int(Stage::kPrepared), int(stage_));
  if (!std::isfinite(hour)) return fail("technique " + describe() + ": hour " + std::to_string(hour) + " is not finite");
  const auto t0 = Clock::now();
  if (auto r = onSetLighting(hour, lights); !r) return std::unexpected(r.error().context("technique " + describe()));
  if (traits_.frame_work == FrameWork::kLighting) costs_.update_ms = msSince(t0);
  stage_ = Stage::kLit;
  return {};
}

Result<void> Technique::update(const glm::dvec3& camera) {
  DRTV_CHECK_LE(int(Stage::kLit), int(stage_));
  if (!(std::isfinite(camera.x) && std::isfinite(camera.y) && std::isfinite(camera.z)))
    return fail("technique " + describe() + ": the camera must be finite");
  const auto t0 = Clock::now();
  if (auto r = onUpdate(camera); !r) return std::unexpected(r.error().context("technique " + describe()));
  if (traits_.frame_work == FrameWork::kUpdate) costs_.update_ms = msSince(t0);
  if (traits_.frame_work == FrameWork::kNone) costs_.update_ms = std::numeric_limits<double>::quiet_NaN();
  return {};
}

Result<std::vector<glm::vec3>> Technique::evaluate(std::span<const SurfacePoint> points) {
  DRTV_CHECK_LE(int(Stage::kLit), int(stage_));
  return onEvaluate(points);
}

Result<void> Technique::setParams(const TechniqueParams& params) {
  if (auto r = onSetParams(params); !r) return std::unexpected(r.error().context("technique " + describe()));
  made_.given = params;
  if (stage_ == Stage::kLit) stage_ = Stage::kPrepared;
  return {};
}

Result<TechniqueStream*> Technique::beginStreaming(const StreamingSetup& setup) {
  DRTV_CHECK_LE(int(Stage::kPrepared), int(stage_));
  if (!std::isfinite(setup.start_hour)) return fail("technique " + describe() + ": the start hour must be finite");
  auto s = onBeginStreaming(setup);
  if (!s) return std::unexpected(s.error().context("technique " + describe()));
  stage_ = Stage::kLit;  // the stream's frames carry the lighting; ambient() reads what it holds
  return s;
}

Result<TechniqueFlight> Technique::prepareFlight(const worlds::World& world, const std::string& where, const StreamingSetup& setup) {
  raytrace::SectorRange block{INT32_MAX, INT32_MIN, INT32_MAX, INT32_MIN};
  for (const SectorEntry& e : setup.manifest.sectors) {
    block.x0 = std::min(block.x0, e.key.ix), block.x1 = std::max(block.x1, e.key.ix);
    block.y0 = std::min(block.y0, e.key.iy), block.y1 = std::max(block.y1, e.key.iy);
  }
  PrepareInput in{world, where, block, 1, 0, nullptr};
  in.streaming = traits_.streams_per_sector;
  if (auto r = prepare(in); !r) return std::unexpected(r.error());
  TechniqueFlight flight;
  if (traits_.streams_per_sector) {
    auto stream = beginStreaming(setup);
    if (!stream) return std::unexpected(stream.error());
    TechniqueStream* ts = *stream;
    flight.sink = ts;
    flight.bytes = costs_.stored_bytes;
    flight.frame = [ts](const streamer::Camera& camera, double time_s, double hour, const std::vector<PointLight>& lights) {
      return ts->frame(camera, time_s, hour, lights);
    };
    return flight;
  }
  flight.bytes = costs_.runtime_bytes;
  flight.frame = [this](const streamer::Camera& camera, double, double hour,
                        const std::vector<PointLight>& lights) -> Result<StreamingFrame> {
    if (auto r = setLighting(hour, lights); !r) return std::unexpected(r.error());
    if (auto r = update(camera.position_m); !r) return std::unexpected(r.error());
    StreamingFrame f;
    f.frame_ms = std::isnan(costs_.update_ms) ? 0.0 : costs_.update_ms;  // FrameWork::kNone: nothing runs
    f.reach = -1;  // bytes: a streamed technique's per-sector state only
    f.idle = true;
    return f;
  };
  return flight;
}

Result<void> Technique::onPrepareBaked(const Manifest&, std::span<const Sector>) {
  return fail("technique " + describe() + " does not prepare from a drtv archive: give it the world");
}

Result<std::vector<glm::vec3>> Technique::onEvaluate(std::span<const SurfacePoint> points) {
  std::vector<glm::vec3> out;
  out.reserve(points.size());
  for (const SurfacePoint& p : points) {
    if (auto r = update(p.position); !r) return std::unexpected(r.error());
    out.push_back(ambient(p.position, p.normal));
  }
  return out;
}

Result<TechniqueStream*> Technique::onBeginStreaming(const StreamingSetup&) {
  return fail("does not stream per sector (no beginStreaming)");
}

Result<void> Technique::onSetParams(const TechniqueParams& params) {
  if (params.empty()) return {};
  return fail("takes no parameters after prepare (" + params.begin()->first + ")");
}

std::vector<KnobRow> knobAround(const std::string& technique, const std::string& knob, const std::string& param,
                                const std::vector<std::string>& values, const std::string& default_value, const std::string& note) {
  std::vector<KnobRow> rows;
  for (const std::string& v : values)
    rows.push_back({knob, v, v == default_value, technique, v == default_value ? TechniqueParams{} : TechniqueParams{{param, v}}, note});
  return rows;
}

Result<TechniqueParams> parseTechniqueParams(std::string_view text) {
  TechniqueParams out;
  size_t at = 0;
  while (at < text.size()) {
    size_t end = text.find(',', at);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view piece = text.substr(at, end - at);
    const size_t eq = piece.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == piece.size())
      return fail("'" + std::string(piece) + "': expected name=value");
    out[std::string(piece.substr(0, eq))] = std::string(piece.substr(eq + 1));
    at = end + 1;
  }
  return out;
}

Result<void> registerTechnique(TechniqueInfo info, TechniqueFactory factory) {
  Registry& r = filledRegistry();
  std::lock_guard lock(r.mutex);
  return add(r, std::move(info), std::move(factory));
}

std::vector<TechniqueInfo> registeredTechniques() {
  Registry& r = filledRegistry();
  std::lock_guard lock(r.mutex);
  std::vector<TechniqueInfo> out;
  for (const Entry& e : r.entries) out.push_back(e.info);
  return out;
}

std::string registeredTechniqueNames() {
  std::string names;
  for (const TechniqueInfo& t : registeredTechniques()) names += (names.empty() ? "" : ", ") + t.name;
  return names;
}

Result<std::unique_ptr<Technique>> makeTechnique(std::string_view name, const TechniqueParams& params) {
  Registry& r = filledRegistry();
  TechniqueFactory factory;
  TechniqueParams merged;
  {
    std::lock_guard lock(r.mutex);
    std::string known;
    for (const Entry& e : r.entries) {
      known += (known.empty() ? "" : ", ") + e.info.name;
      if (e.info.name == name) factory = e.factory, merged = e.info.preset;
    }
    if (!factory) return fail("unknown technique '" + std::string(name) + "' (known: " + known + ")");
  }
  for (const auto& [k, v] : params) merged[k] = v;
  auto t = factory(TechniqueMade{std::string(name), merged});
  if (!t) return std::unexpected(t.error().context("technique " + std::string(name)));
  return t;
}

}  // namespace drtv::eval
