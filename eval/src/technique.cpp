// The technique registry (technique.h).
#include "drtv/eval/technique.h"

#include <mutex>

#include "techniques.h"

namespace drtv::eval {
namespace {

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
void builtinTechniques(Registry& r) {
  for (auto& [info, factory] : drtvTechniques()) (void)add(r, std::move(info), std::move(factory));
  for (auto& [info, factory] : probeReferenceTechniques()) (void)add(r, std::move(info), std::move(factory));
  for (auto& [info, factory] : lpvTechniques()) (void)add(r, std::move(info), std::move(factory));
  for (auto& [info, factory] : sweepTechniques()) (void)add(r, std::move(info), std::move(factory));
  for (auto& [info, factory] : ambientCubeTechniques()) (void)add(r, std::move(info), std::move(factory));
}

Registry& registry() {
  static Registry* r = [] {
    auto* reg = new Registry;
    builtinTechniques(*reg);
    return reg;
  }();
  return *r;
}

}  // namespace

Result<void> Technique::prepareBaked(const Manifest&, std::span<const Sector>) {
  return fail("technique " + describe() + " does not prepare from a drtv archive: give it the world");
}

Result<std::vector<glm::vec3>> Technique::evaluate(std::span<const SurfacePoint> points) {
  std::vector<glm::vec3> out;
  out.reserve(points.size());
  for (const SurfacePoint& p : points) {
    if (auto r = update(p.position); !r) return std::unexpected(r.error());
    out.push_back(ambient(p.position, p.normal));
  }
  return out;
}

std::optional<runtime::RuntimeOptions> Technique::streamingRuntime(const Manifest&) const { return std::nullopt; }

Result<TechniqueStream*> Technique::beginStreaming(const StreamingSetup&) {
  return fail("technique " + describe() + ": does not stream per sector (no beginStreaming)");
}

Result<void> Technique::setParams(const TechniqueParams& params) {
  if (params.empty()) return {};
  return fail("technique " + describe() + " takes no parameters after prepare (" + params.begin()->first + ")");
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
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  return add(r, std::move(info), std::move(factory));
}

std::vector<TechniqueInfo> registeredTechniques() {
  Registry& r = registry();
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
  Registry& r = registry();
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
  auto t = factory(merged);
  if (!t) return std::unexpected(t.error().context("technique " + std::string(name)));
  return t;
}

}  // namespace drtv::eval
