// drtv query <archive | URL> --at x,y,z --normal x,y,z --time HH:MM [--json]
// Ambient irradiance at a point and its parts (sun bounce, sky bounce, direct sky, local lights),
// and which path produced it (volume, distant ambient, interior), from a baked archive alone.
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "archive_source.h"
#include "commands.h"
#include "drtv/formats/archive.h"
#include "drtv/runtime/runtime.h"
#include "drtv/streamer/residency.h"

namespace drtv::app {
namespace {

struct QueryOptions {
  std::string path, at, normal = "0,0,1", time = "12:00";
  bool json = false;
};

nlohmann::json rgb(const glm::vec3& v) { return {v.r, v.g, v.b}; }

Result<void> runQuery(const QueryOptions& o) {
  auto at = parseVec3(o.at, "--at");
  if (!at) return std::unexpected(at.error());
  auto normal = parseVec3(o.normal, "--normal");
  if (!normal) return std::unexpected(normal.error());
  auto hour = parseTimeOfDay(o.time);
  if (!hour) return std::unexpected(hour.error());
  auto archive = openArchive(o.path);
  if (!archive) return std::unexpected(archive.error());
  const Manifest& m = archive->manifest;

  // The sectors a streamer would hold around this camera (streamer::residentBlock).
  const SectorRange block = streamer::residentBlock(*at);
  std::vector<Sector> sectors;
  for (const SectorEntry& e : m.sectors) {
    if (!block.contains(e.key)) continue;
    auto s = readSector(*archive, e.key);
    if (!s) return std::unexpected(s.error());
    sectors.push_back(std::move(*s));
  }
  const uint32_t baked = runtime::componentsFromEffects(m.effects);
  // The probe the index grid names at the point (what the volume texel there was filled from),
  // for reading a leak or a dark spot back to its probe; from the first (total) evaluation.
  struct NamedProbe {
    bool valid = false;
    SectorKey sector{};
    int index = 0;
    glm::dvec3 position{0.0};
    glm::vec3 shaded{0.f};  // its colours shaded for the normal, all components
  } probe;
  auto evaluate = [&](uint32_t components) -> Result<runtime::AmbientSample> {
    runtime::RuntimeOptions options = runtime::optionsForEffects(m.effects);
    options.components = components;
    auto made = runtime::runtimeForSectors(m, options, *hour, sectors);
    if (!made) return std::unexpected(made.error().context(o.path));
    std::unique_ptr<runtime::Runtime> rt = std::move(*made);
    rt->update(*at);
    if (components == baked) {
      const runtime::ProbeRef ref = rt->cache().probeAt(*at);
      if (ref.valid()) {
        probe.valid = true;
        probe.sector = rt->cache().slot(ref.slot).key;
        probe.index = ref.index;
        probe.position = rt->cache().worldPosition(ref);
        probe.shaded = runtime::shade(m.representation, rt->cache().colours(ref), runtime::ambientNormal(glm::vec3(*normal)));
      }
    }
    return rt->ambient(*at, glm::vec3(*normal));
  };
  auto total = evaluate(baked);
  if (!total) return std::unexpected(total.error());
  struct Part {
    const char* name;
    runtime::Component component;
    glm::vec3 value{0.f};
    bool baked = false;
  };
  Part parts[] = {{"sun_bounce", runtime::kComponentSunBounce}, {"sky_bounce", runtime::kComponentSkyBounce},
                  {"direct_sky", runtime::kComponentDirectSky}, {"local_lights", runtime::kComponentLocalLights}};
  for (Part& p : parts) {
    p.baked = (baked & p.component) != 0;
    if (!p.baked) continue;
    auto a = evaluate(p.component);
    if (!a) return std::unexpected(a.error());
    p.value = a->irradiance;
  }
  const char* path = total->interior >= 0 && total->interior_weight > 0.f ? "interior"
                     : total->volume_weight >= 1.f                         ? "volume"
                     : total->volume_weight > 0.f                          ? "volume+distant"
                                                                           : "distant";
  if (o.json) {
    nlohmann::json j;
    j["archive"] = o.path;
    j["at"] = {at->x, at->y, at->z};
    j["normal"] = {normal->x, normal->y, normal->z};
    j["time_h"] = *hour;
    j["sectors_loaded"] = sectors.size();
    j["representation"] = representationName(m.representation);
    j["irradiance"] = rgb(total->irradiance);
    j["path"] = path;
    j["volume_weight"] = total->volume_weight;
    j["distant"] = rgb(total->distant);
    j["interior"] = total->interior >= 0 ? nlohmann::json(m.interiors[total->interior].name) : nlohmann::json(nullptr);
    j["interior_weight"] = total->interior_weight;
    j["fine_weight"] = total->fine_weight;
    j["fine"] = total->fine_weight > 0.f ? rgb(total->fine) : nlohmann::json(nullptr);
    nlohmann::json pj = nlohmann::json::object();
    for (const Part& p : parts) pj[p.name] = p.baked ? rgb(p.value) : nlohmann::json(nullptr);
    j["parts"] = pj;
    if (probe.valid)
      j["probe"] = {{"sector", {probe.sector.ix, probe.sector.iy}},
                    {"index", probe.index},
                    {"position", {probe.position.x, probe.position.y, probe.position.z}},
                    {"shaded", rgb(probe.shaded)}};
    else
      j["probe"] = nullptr;
    j["note"] = "parts are evaluated one at a time through the 8-bit volume; they sum to the total up to quantisation and the final clamp";
    std::puts(j.dump(2).c_str());
    return {};
  }
  std::printf("ambient irradiance at (%.2f, %.2f, %.2f), normal (%.2f, %.2f, %.2f), %s: %.5f %.5f %.5f\n", at->x, at->y,
              at->z, normal->x, normal->y, normal->z, o.time.c_str(), total->irradiance.r, total->irradiance.g,
              total->irradiance.b);
  std::printf("representation: %s\n", representationName(m.representation));
  std::printf("path: %s (volume weight %.2f)%s%s\n", path, total->volume_weight,
              total->interior >= 0 ? ", interior " : "", total->interior >= 0 ? m.interiors[total->interior].name.c_str() : "");
  for (const Part& p : parts) {
    if (p.baked)
      std::printf("  %-13s %.5f %.5f %.5f\n", p.name, p.value.r, p.value.g, p.value.b);
    else
      std::printf("  %-13s not baked\n", p.name);
  }
  std::printf("  %-13s %.5f %.5f %.5f\n", "distant", total->distant.r, total->distant.g, total->distant.b);
  if (total->fine_weight > 0.f)
    std::printf("fine level near surfaces: weight %.2f, %.5f %.5f %.5f (blended over the path above)\n", total->fine_weight,
                total->fine.r, total->fine.g, total->fine.b);
  else
    std::printf("fine level near surfaces: no covered probe sees the point\n");
  if (probe.valid)
    std::printf("probe named here: sector (%d,%d) #%d at (%.2f, %.2f, %.2f), shaded for the normal %.5f %.5f %.5f\n", probe.sector.ix,
                probe.sector.iy, probe.index, probe.position.x, probe.position.y, probe.position.z, probe.shaded.r, probe.shaded.g,
                probe.shaded.b);
  std::printf("(%zu sectors loaded; parts go through the 8-bit volume one at a time)\n", sectors.size());
  return {};
}

}  // namespace

Command registerQuery(CLI::App& app) {
  auto o = std::make_shared<QueryOptions>();
  CLI::App* sub = app.add_subcommand("query", "Ambient irradiance and its parts at a point of a baked archive");
  sub->add_option("archive", o->path, "Baked archive (.drtv), a path or an http(s):// URL")->required();
  sub->add_option("--at", o->at, "World position x,y,z in metres")->required();
  sub->add_option("--normal", o->normal, "Surface normal x,y,z (normalised here; default 0,0,1)")->check(nonZeroVec3());
  sub->add_option("--time", o->time, "Time of day HH:MM (default 12:00)");
  sub->add_flag("--json", o->json, "Print JSON instead of text");
  return {sub, [o]() -> Result<void> { return runQuery(*o); }, &o->path};
}

}  // namespace drtv::app
