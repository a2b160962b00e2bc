// drtv info <world.json | file.gltf | file.glb | archive | http(s)://.../archive> [--json] [--probes]
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "archive_source.h"
#include "commands.h"
#include "drtv/formats/archive.h"
#include "drtv/worlds/load.h"
#include "drtv/worlds/summary.h"

namespace drtv::app {
namespace {

struct InfoOptions {
  std::string path;
  bool json = false;
  bool probes = false;  // an archive's probes, one each
};

nlohmann::json vec3Json(const glm::dvec3& v) { return {v.x, v.y, v.z}; }

// The names of a probe's flags (probe.h), comma-separated; "-" for none.
std::string flagNames(uint16_t f) {
  static constexpr std::pair<uint16_t, const char*> kNames[] = {
      {kProbeRelocated, "relocated"}, {kProbeVegetation, "vegetation"}, {kProbeInterior, "interior"},
      {kProbeManual, "manual"},       {kProbeCovered, "covered"},       {kProbeLightSource, "light-source"},
      {kProbeStacked, "stacked"}};
  std::string out;
  for (const auto& [bit, name] : kNames)
    if (f & bit) out += (out.empty() ? "" : ",") + std::string(name);
  return out.empty() ? "-" : out;
}

// Every probe of every sector: sector, index, world position, flags (drtv info --probes). The
// sectors are read and checked as the runtime reads them.
Result<void> archiveProbes(const InfoOptions& o, const OpenedArchive& a) {
  nlohmann::json list = nlohmann::json::array();
  if (!o.json) std::printf("%-12s %5s %10s %10s %8s  %s\n", "sector", "probe", "x", "y", "z", "flags");
  for (const SectorEntry& e : a.manifest.sectors) {
    auto sector = readSector(a, e.key);
    if (!sector) return std::unexpected(sector.error());
    const double ox = double(e.key.ix) * kSectorSizeM, oy = double(e.key.iy) * kSectorSizeM;
    for (size_t i = 0; i < sector->probes.size(); ++i) {
      const ProbeRecord& p = sector->probes[i];
      const glm::dvec3 w(ox + p.position[0], oy + p.position[1], p.position[2]);
      if (o.json)
        list.push_back({{"sector", {e.key.ix, e.key.iy}}, {"index", i}, {"position", vec3Json(w)}, {"flags", flagNames(p.flags)}});
      else
        std::printf("%-12s %5zu %10.2f %10.2f %8.2f  %s\n", toString(e.key).c_str(), i, w.x, w.y, w.z, flagNames(p.flags).c_str());
    }
  }
  if (o.json) std::puts(list.dump(2).c_str());
  return {};
}


Result<void> archiveInfo(const InfoOptions& o) {
  auto archive = openArchive(o.path);
  if (!archive) return std::unexpected(archive.error());
  if (o.probes) return archiveProbes(o, *archive);
  const Manifest& m = archive->manifest;
  size_t probes = 0, min_probes = SIZE_MAX, max_probes = 0, raw = 0, compressed = 0, lprt_sectors = 0;
  size_t covered = 0, covered_sectors = 0;
  for (const SectorEntry& e : m.sectors) {
    probes += e.probes;
    covered += e.covered;
    covered_sectors += e.covered > 0;
    min_probes = std::min<size_t>(min_probes, e.probes);
    max_probes = std::max<size_t>(max_probes, e.probes);
    raw += e.raw_bytes;
    compressed += e.compressed_bytes;
    lprt_sectors += e.lprt_sources > 0;
  }
  const size_t n = m.sectors.size();
  if (n == 0) min_probes = 0;
  const double mean = n ? double(probes) / double(n) : 0.0;
  if (o.json) {
    nlohmann::json j;
    j["kind"] = "archive";
    j["path"] = o.path;
    j["version"] = m.version;
    j["bounds_min"] = vec3Json(m.bounds_min);
    j["bounds_max"] = vec3Json(m.bounds_max);
    j["sector_size_m"] = m.sector_size_m;
    j["effects"] = effectsToString(m.effects);
    j["sectors"] = n;
    j["sectors_with_lprt"] = lprt_sectors;
    j["probes"] = {{"total", probes}, {"min", min_probes}, {"mean", mean}, {"max", max_probes}, {"covered", covered}};
    j["bytes"] = {{"raw", raw}, {"compressed", compressed},
                  {"raw_per_sector", n ? double(raw) / n : 0.0}, {"compressed_per_sector", n ? double(compressed) / n : 0.0}};
    j["lights"] = m.lights.size();
    j["interiors"] = m.interiors.size();
    nlohmann::json volumes = nlohmann::json::array();
    for (const InteriorVolume& v : m.interiors)
      volumes.push_back({{"name", v.name}, {"min", vec3Json(v.min)}, {"max", vec3Json(v.max)}, {"probe", vec3Json(v.probe_position)},
                         {"blend_m", v.blend_distance_m}});
    j["interior_volumes"] = volumes;
    nlohmann::json settings = nlohmann::json::object();
    for (const auto& [k, v] : m.settings) settings[k] = v;
    j["settings"] = settings;
    nlohmann::json per = nlohmann::json::array();
    for (const SectorEntry& e : m.sectors)
      per.push_back({{"ix", e.key.ix}, {"iy", e.key.iy}, {"probes", e.probes}, {"lprt_sources", e.lprt_sources},
                     {"covered", e.covered}, {"raw_bytes", e.raw_bytes}, {"compressed_bytes", e.compressed_bytes}});
    j["per_sector"] = per;
    std::puts(j.dump(2).c_str());
    return {};
  }
  std::printf("archive: %s (version %u)\n", o.path.c_str(), m.version);
  std::printf("bounds: [%.1f, %.1f, %.1f] .. [%.1f, %.1f, %.1f] m\n", m.bounds_min.x, m.bounds_min.y, m.bounds_min.z,
              m.bounds_max.x, m.bounds_max.y, m.bounds_max.z);
  std::printf("effects: %s\n", effectsToString(m.effects).c_str());
  std::printf("sectors: %zu of %.0f m (%zu with LPRT)\n", n, m.sector_size_m, lprt_sectors);
  std::printf("probes: %zu (per sector min %zu, mean %.1f, max %zu)\n", probes, min_probes, mean, max_probes);
  std::printf("covered probes: %zu, with visibility maps of %zu bytes in %zu sectors\n", covered, covered * kVisBytesPerProbe,
              covered_sectors);
  std::printf("bytes: %zu raw, %zu compressed (per sector %.0f raw, %.0f compressed)\n", raw, compressed,
              n ? double(raw) / n : 0.0, n ? double(compressed) / n : 0.0);
  std::printf("lights: %zu, interiors: %zu\n", m.lights.size(), m.interiors.size());
  for (const InteriorVolume& v : m.interiors)
    std::printf("interior '%s': [%.2f, %.2f, %.2f] .. [%.2f, %.2f, %.2f] m, probe (%.2f, %.2f, %.2f), blend %.2f m\n", v.name.c_str(),
                v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z, v.probe_position.x, v.probe_position.y, v.probe_position.z,
                double(v.blend_distance_m));
  for (const auto& [k, v] : m.settings) std::printf("setting %s: %s\n", k.c_str(), v.c_str());
  std::printf("%-12s %7s %6s %10s %12s\n", "sector", "probes", "lprt", "raw B", "compressed B");
  for (const SectorEntry& e : m.sectors)
    std::printf("%-12s %7u %6u %10u %12u\n", toString(e.key).c_str(), e.probes, e.lprt_sources, e.raw_bytes, e.compressed_bytes);
  return {};
}

Result<void> worldInfo(const InfoOptions& o) {
  auto world = worlds::loadWorld(o.path);
  if (!world) return std::unexpected(world.error());
  const worlds::WorldSummary s = worlds::summarize(*world);
  if (o.json) {
    nlohmann::json j;
    j["kind"] = "world";
    j["path"] = o.path;
    j["name"] = s.name;
    j["meshes"] = s.meshes;
    j["instances"] = s.instances;
    nlohmann::json by_class;
    for (size_t c = 0; c < 4; ++c) by_class[worlds::instanceClassName(static_cast<worlds::InstanceClass>(c))] = s.instances_by_class[c];
    j["instances_by_class"] = by_class;
    j["triangles"] = s.triangles;
    if (!s.bounds.empty()) {
      j["bounds_min"] = vec3Json(s.bounds.min);
      j["bounds_max"] = vec3Json(s.bounds.max);
    }
    j["sectors"] = {{"count", s.sectors}, {"x", {s.sector_min_x, s.sector_max_x}}, {"y", {s.sector_min_y, s.sector_max_y}}};
    j["effects"] = effectsToString(s.effects);
    j["effects_explicit"] = s.effects_explicit;
    j["lights"] = s.lights;
    j["interiors"] = s.interiors;
    nlohmann::json materials = nlohmann::json::object();
    for (const auto& [name, count] : worlds::materialCountFields(s.materials)) materials[name] = count;
    j["materials"] = materials;
    j["notes"] = world->notes;
    std::puts(j.dump(2).c_str());
    return {};
  }
  std::fputs(worlds::toString(s).c_str(), stdout);
  for (const std::string& note : world->notes) std::printf("note: %s\n", note.c_str());
  return {};
}

}  // namespace

Command registerInfo(CLI::App& app) {
  auto o = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand("info", "Describe a world (.json, .gltf, .glb) or a baked archive");
  sub->add_option("path", o->path, "World file, archive, or an archive's http(s):// URL")->required();
  sub->add_flag("--json", o->json, "Print JSON instead of text");
  sub->add_flag("--probes", o->probes, "An archive's probes, one a line: sector, index, world position, flags");
  return {sub, [o]() -> Result<void> {
            if (isArchiveUrl(o->path)) return archiveInfo(*o);  // a URL names an archive (docs/streamer.md)
            if (!std::filesystem::exists(o->path)) return fail(o->path + ": no such file");
            auto version = peekArchiveVersion(o->path);
            if (version) return archiveInfo(*o);
            // A .drtv file is an archive whatever its bytes say: its own error (truncated, bad
            // magic) tells more than "unknown world file type".
            std::string ext = std::filesystem::path(o->path).extension().string();
            std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
            if (ext == ".drtv") return std::unexpected(version.error());
            if (o->probes) return fail(o->path + ": --probes lists an archive's probes; this is a world file");
            return worldInfo(*o);
          }, &o->path};
}

}  // namespace drtv::app
