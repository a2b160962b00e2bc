// The bake's sector directory: its stamp and the shards' statuses (bake_directory.h). Moved from
// bake.cpp unchanged.
#include "bake_directory.h"

#include <xxhash.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>

#include "atomic_file.h"
#include "sector_journal.h"

namespace drtv::baker::detail {
namespace fs = std::filesystem;
namespace {

// Version of what the sector journals hold; part of the resume fingerprint (2: journals instead
// of a pair of files per sector; 3: records keep their LPRT source positions for packing; 4: a
// placement pass names LPRT sources, records keep no positions; 6: placement keeps a clearance
// and its records count dropped_gap; 7: index cells inside geometry take a neighbour's choice).
constexpr int kBakeFormat = 7;

}  // namespace

Result<std::vector<uint8_t>> readFile(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return fail(path.string() + ": cannot open");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return bytes;
}

// What a resumed bake must share with the one that wrote the journals: the geometry, effects,
// journal format, settings and every field of every interior.
uint64_t bakeFingerprint(const raytrace::WorldGeometry& geometry, const worlds::World& world, const BakeSettings& settings,
                         uint32_t effects) {
  uint64_t fingerprint = raytrace::hashKey(geometry.fingerprint(), effects, kBakeFormat);
  // Text hashed with XXH3, not std::hash: the stamp outlives the build (std::hash may change with
  // the standard library, and a rebuilt drtv would then refuse to resume its own bake).
  auto textHash = [](const std::string& t) { return uint64_t(XXH3_64bits(t.data(), t.size())); };
  for (const auto& [k, v] : settings.describe()) fingerprint = raytrace::hashKey(fingerprint, textHash(k + "=" + v));
  // Interiors decide probe flags and indices: every field, exactly (bit patterns, not text).
  for (const InteriorVolume& v : world.interiors) {
    fingerprint = raytrace::hashKey(fingerprint, textHash(v.name));
    for (const glm::dvec3& p : {v.probe_position, v.min, v.max})
      for (int a = 0; a < 3; ++a) fingerprint = raytrace::hashKey(fingerprint, std::bit_cast<uint64_t>(p[a]));
    fingerprint = raytrace::hashKey(fingerprint, uint64_t(std::bit_cast<uint32_t>(v.blend_distance_m)));
  }
  return fingerprint;
}

// The fingerprint as bake.txt and the shards' status files write it: 16 hex digits.
std::string fingerprintText(uint64_t fingerprint) {
  char text[32];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(fingerprint));
  return text;
}

// Creates `dir` and stamps it with `fingerprint`; a directory stamped by a different bake is an
// error unless `fresh` (then its journals are removed).
Result<void> claimSectorDirectory(const fs::path& dir, uint64_t fingerprint, bool fresh) {
  const std::string fp = fingerprintText(fingerprint);
  const char* fp_text = fp.c_str();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  const fs::path stamp = dir / "bake.txt";
  if (fs::exists(stamp, ec)) {
    auto old = readFile(stamp);
    const std::string text = old ? std::string(old->begin(), old->end()) : "";
    if (text != fp_text) {
      if (!fresh)
        return fail(dir.string() + ": holds sectors of a different bake (other world, quality, settings or drtv version); pass --fresh to discard them");
      if (auto r = detail::removeJournals(dir); !r) return std::unexpected(r.error());
    }
  }
  // Shards on a farm write the same stamp at once (atomic_file.h).
  return detail::writeFileAtomically(stamp, fp_text);
}

namespace {
// "estimated" -> "their estimated costs"; "measured <digest>" -> "the times of a bake report (<digest>)".
std::string splitText(const std::string& split) {
  if (split == "estimated") return "their estimated costs (no --costs)";
  if (split.rfind("measured ", 0) == 0) return "the times of a bake report (--costs, digest " + split.substr(9) + ")";
  return "'" + split + "'";
}
}  // namespace

// The shards' status files (shard.h) in `dir`, each checked against the merge's bake: a shard
// baked from another world or with other settings is named, with what differs.
Result<std::vector<ShardStatus>> shardsOfThisBake(const fs::path& dir, const std::string& fingerprint, const std::string& world_name,
                                                  const BakeSettings& settings, const std::string& split) {
  auto statuses = readShardStatuses(dir);
  if (!statuses) return std::unexpected(statuses.error());
  for (const ShardStatus& s : *statuses) {
    // Shards that split otherwise may have left sectors to nobody, and the merge would name the
    // wrong shards for them: one --costs for all (sector_costs.h).
    if (s.split != split && (s.fingerprint.empty() || s.fingerprint == fingerprint))
      return fail(shardStatusFile(dir, s.index, s.count).string() + ": shard " + std::to_string(s.index) + "/" +
                  std::to_string(s.count) + " split the sectors by " + splitText(s.split) + ", this merge by " + splitText(split) +
                  "; give every shard and the merge the same --costs (or none)");
    if (s.fingerprint.empty() || s.fingerprint == fingerprint) continue;  // empty: it failed before it knew
    const std::map<std::string, std::string> theirs(s.settings.begin(), s.settings.end());
    std::string differ;
    for (const auto& [key, value] : settings.describe()) {
      const auto it = theirs.find(key);
      const std::string there = it == theirs.end() ? "unset" : it->second;
      if (there != value) differ += (differ.empty() ? "" : ", ") + key + " " + there + " there, " + value + " here";
    }
    std::string why = differ.empty() ? "another world (its geometry, effects or interiors differ)" : "other settings (" + differ + ")";
    if (s.world != world_name) why += "; it baked '" + s.world + "', this merge '" + world_name + "'";
    return fail(shardStatusFile(dir, s.index, s.count).string() + ": shard " + std::to_string(s.index) + "/" +
                std::to_string(s.count) + " was baked from " + why + "; rebake it like the others (--fresh discards its sectors)");
  }
  return statuses;
}

// Why the sectors `keys[i]` with !have[i] are missing, shard by shard, as the shards' status files
// tell it: which shard of each split owns them, and whether it failed (its error), is running or
// was killed, says it is done (its journal lost them), or never ran.
std::string missingShards(const fs::path& dir, const std::vector<SectorKey>& keys, const std::vector<uint64_t>& costs,
                          const std::vector<uint8_t>& have, const std::vector<ShardStatus>& statuses) {
  std::set<int> splits;
  for (const ShardStatus& s : statuses) splits.insert(s.count);
  if (splits.empty()) return "; no shard has written a status in " + dir.string();
  std::string out;
  for (const int n : splits) {
    std::map<int, std::pair<SectorKey, size_t>> owners;  // shard -> (first missing sector, count)
    const std::vector<int> owner = shardOwners(costs, n);
    for (size_t i = 0; i < keys.size(); ++i)
      if (!have[i]) {
        const auto it = owners.try_emplace(owner[i], keys[i], 0).first;
        ++it->second.second;
      }
    for (const auto& [k, first] : owners) {
      const auto st = std::find_if(statuses.begin(), statuses.end(), [&](const ShardStatus& s) { return s.count == n && s.index == k; });
      const std::string shard = "shard " + std::to_string(k) + "/" + std::to_string(n);
      const std::string owned = " (" + std::to_string(first.second) + " of its sectors, first " + toString(first.first) + ")";
      out += "; " + shard;
      if (st == statuses.end()) out += " has not run" + owned;
      else if (st->state == ShardStatus::State::kFailed) out += " failed" + owned + ": " + st->error;
      else if (st->state == ShardStatus::State::kRunning) out += " is running or was killed" + owned;
      else out += " says it is done but its journal sectors-" + std::to_string(k) + "-of-" + std::to_string(n) + ".log lacks" + owned;
    }
  }
  return out;
}

}  // namespace drtv::baker::detail
