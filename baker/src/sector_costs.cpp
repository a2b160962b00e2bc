// What each sector of a bake costs (see sector_costs.h).
#include "drtv/baker/sector_costs.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>
#include <xxhash.h>

#include "bake_directory.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {
namespace {
// The most a report's sector may say it took (31 years): bounds the units (microseconds) well
// inside shardOwners' 64-bit sums, whatever the report holds.
constexpr double kMaxSectorSeconds = 1e9;
}  // namespace

Result<MeasuredCosts> readMeasuredCosts(const std::filesystem::path& report) {
  const std::string name = report.string();
  auto bad = [&](const std::string& why) -> Result<MeasuredCosts> { return fail(name + ": " + why); };
  std::ifstream in(report, std::ios::binary);
  if (!in) return bad("cannot open (--costs takes an earlier bake's bake-report.json)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    return bad(std::string("not JSON: ") + e.what());
  }
  if (!j.is_object() || !j.contains("per_sector") || !j["per_sector"].is_array())
    return bad("not a bake report (no \"per_sector\" array; --costs takes an earlier bake's bake-report.json)");
  MeasuredCosts m;
  m.file = name;
  if (!j.contains("geometry_fingerprint") || !j["geometry_fingerprint"].is_string() ||
      j["geometry_fingerprint"].get<std::string>().size() != 16)
    return bad("has no \"geometry_fingerprint\" (written by a drtv before it); bake again to measure the sectors");
  m.geometry = j["geometry_fingerprint"].get<std::string>();
  if (j.contains("world") && j["world"].is_string()) m.world = j["world"].get<std::string>();
  if (j.contains("threads") && j["threads"].is_number_integer()) m.threads = j["threads"].get<int>();
  double seconds = 0, units = 0;
  const auto& per = j["per_sector"];
  for (size_t i = 0; i < per.size(); ++i) {
    const auto& s = per[i];
    const std::string where = "per_sector[" + std::to_string(i) + "]";
    auto whole = [&](const char* key) -> std::optional<int64_t> {
      if (!s.is_object() || !s.contains(key) || !s[key].is_number_integer()) return std::nullopt;
      return s[key].get<int64_t>();
    };
    const auto ix = whole("ix"), iy = whole("iy"), triangles = whole("triangles");
    if (!ix || !iy || !triangles || *triangles < 0 || *ix < INT32_MIN || *ix > INT32_MAX || *iy < INT32_MIN || *iy > INT32_MAX)
      return bad(where + ": needs whole numbers \"ix\", \"iy\" and \"triangles\" >= 0");
    if (!s.contains("total_s") || !s["total_s"].is_number() || !std::isfinite(s["total_s"].get<double>()) || s["total_s"].get<double>() < 0 ||
        s["total_s"].get<double>() > kMaxSectorSeconds)
      return bad(where + ": \"total_s\" must be a number of seconds from 0 to 1e9");
    const double t = s["total_s"].get<double>();
    if (t <= 0) continue;  // resumed from a journal without times, or not baked: the fit covers it
    const SectorKey key{int32_t(*ix), int32_t(*iy)};
    if (!m.seconds.emplace(key, t).second) return bad(where + ": sector " + toString(key) + " is listed twice");
    seconds += t;
    units += 1.0 + double(*triangles);
  }
  // The digest over the map's order (keys sorted), the bits of each time.
  std::vector<int64_t> words;
  words.reserve(3 * m.seconds.size());
  for (const auto& [key, t] : m.seconds) words.insert(words.end(), {key.ix, key.iy, std::bit_cast<int64_t>(t)});
  m.digest = detail::fingerprintText(XXH3_64bits(words.data(), words.size() * sizeof(int64_t)));
  if (m.seconds.empty()) return bad("no sector has a bake time above 0");
  // The memory the bake measured, where the report has it (a figure beside the estimate, never a
  // split): out-of-range or missing values read as none.
  const auto bytes = [&](const nlohmann::json& parent, const char* key) -> uint64_t {
    if (!parent.is_object() || !parent.contains(key) || !parent[key].is_number_unsigned()) return 0;
    const uint64_t v = parent[key].get<uint64_t>();
    return v < (uint64_t(1) << 50) ? v : 0;
  };
  if (j.contains("memory")) m.peak_bytes = bytes(j["memory"], "peak_resident_bytes");
  if (j.contains("shard_balance")) m.shard_peak_bytes = bytes(j["shard_balance"], "most_peak_resident_bytes");
  if (j.contains("shards") && j["shards"].is_array()) m.shards = int(std::min<size_t>(j["shards"].size(), 1 << 20));
  m.seconds_per_unit = seconds / units;
  return m;
}

SectorCosts sectorCosts(const raytrace::WorldGeometry& geometry, std::span<const SectorKey> keys, double halo_m,
                        const MeasuredCosts* measured) {
  SectorCosts out;
  out.units.resize(keys.size());
  for (size_t i = 0; i < keys.size(); ++i) out.units[i] = 1 + geometry.gatherEstimate(keys[i], halo_m);
  return measured ? measuredCosts(std::move(out), keys, geometry.fingerprint(), *measured) : out;
}

SectorCosts measuredCosts(SectorCosts estimated, std::span<const SectorKey> keys, uint64_t geometry_fingerprint,
                          const MeasuredCosts& measured) {
  SectorCosts out = std::move(estimated);
  if (measured.geometry != detail::fingerprintText(geometry_fingerprint)) {
    // Another world: its rate predicts, the triangles split.
    out.seconds_per_unit = measured.seconds_per_unit;
    return out;
  }
  out.split = "measured " + measured.digest;
  constexpr double kUnitsPerSecond = 1e6;  // microseconds
  out.seconds_per_unit = 1.0 / kUnitsPerSecond;
  for (size_t i = 0; i < keys.size(); ++i) {
    const auto it = measured.seconds.find(keys[i]);
    const double s = std::min(kMaxSectorSeconds, it != measured.seconds.end() ? it->second : double(out.units[i]) * measured.seconds_per_unit);
    if (it != measured.seconds.end()) ++out.measured;
    // At least 1: a sector is never free, and the units stay within shardOwners' sums.
    out.units[i] = uint64_t(std::clamp(std::llround(s * kUnitsPerSecond), 1ll, 1ll << 50));
  }
  return out;
}

}  // namespace drtv::baker
