// The bake's sector directory (`<archive>.sectors/`, bake.cpp): the stamp that says which bake
// its journals belong to, and what the shards' status files (shard.h) say when a merge finds a
// shard of another bake or sectors missing. Private to the baker.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "drtv/baker/bake.h"
#include "drtv/baker/shard.h"
#include "drtv/formats/error.h"
#include "drtv/raytrace/sampling.h"
#include "drtv/raytrace/world_geometry.h"
#include "drtv/worlds/world.h"

namespace drtv::baker::detail {

// The whole of a file's bytes; an error names the file.
Result<std::vector<uint8_t>> readFile(const std::filesystem::path& path);

// What a resumed bake must share with the one that wrote the journals: the geometry, effects,
// journal format, settings and every field of every interior.
uint64_t bakeFingerprint(const raytrace::WorldGeometry& geometry, const worlds::World& world, const BakeSettings& settings,
                         uint32_t effects);
// The fingerprint as bake.txt and the shards' status files write it: 16 hex digits.
std::string fingerprintText(uint64_t fingerprint);
// Creates `dir` and stamps it with `fingerprint`; a directory stamped by a different bake is an
// error unless `fresh` (then its journals are removed).
Result<void> claimSectorDirectory(const std::filesystem::path& dir, uint64_t fingerprint, bool fresh);

// The shards' status files in `dir`, each checked against the merge's bake: a shard baked from
// another world or with other settings is named, with what differs, and so is one that split the
// sectors otherwise than `split` (SectorCosts::split: another --costs, or none).
Result<std::vector<ShardStatus>> shardsOfThisBake(const std::filesystem::path& dir, const std::string& fingerprint,
                                                  const std::string& world_name, const BakeSettings& settings,
                                                  const std::string& split);
// Why the sectors `keys[i]` with !have[i] are missing, shard by shard, as the shards' status files
// tell it: which shard of each split owns them, and whether it failed (its error), is running or
// was killed, says it is done (its journal lost them), or never ran.
std::string missingShards(const std::filesystem::path& dir, const std::vector<SectorKey>& keys, const std::vector<uint64_t>& costs,
                          const std::vector<uint8_t>& have, const std::vector<ShardStatus>& statuses);

}  // namespace drtv::baker::detail
