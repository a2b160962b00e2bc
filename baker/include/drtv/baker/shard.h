// drtv/baker/shard.h — a bake's shards as a scheduler runs them: which shard this process is
// (from the command line or the scheduler's environment), and what each shard left in the sector
// folder for the merge and for `drtv farm status` to read.
//
// A shard k of N bakes the sectors that shardOwners gives it: the N shards balanced by each
// sector's estimated cost, the same split in every process of the bake (bake.h). Each shard writes
// only files named by its own k and N in "<archive>.sectors/":
//   sectors-<k>-of-<N>.log     its sector journal (sector_journal.h), resumed when it reruns
//   placement-<k>-of-<N>.log   its placement journal (LPRT bakes only)
//   shard-<k>-of-<N>.json      its status: running, done or failed (with the error), the bake's
//                              fingerprint and settings, the split, the sectors it owns, its wall time
// and all shards write the same stamp, bake.txt, each through a temporary file of its own.
//
// Schedulers (docs/baker.md, "Baking on a farm"):
//   Slurm job arrays set SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN, SLURM_ARRAY_TASK_STEP and
//   SLURM_ARRAY_TASK_COUNT (sbatch(1), "OUTPUT ENVIRONMENT VARIABLES"): k = (ID - MIN) / STEP.
//   Kubernetes Indexed Jobs set JOB_COMPLETION_INDEX (0 .. completions-1) but not the count:
//   it comes from the command line ("k8s/N") or from DRTV_SHARD_COUNT.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "drtv/formats/error.h"

namespace drtv::baker {

struct ShardSpec {
  int index = 0;  // k, 0 <= k < count
  int count = 1;  // N
};

// Which of `count` shards bakes each sector, from the sectors' costs (in key order):
// the longest-processing-time-first rule, each sector from the costliest down (ties: key order)
// to the shard with the least cost so far (ties: the lowest index). A pure function: every shard
// of a bake computes the same split. The costs are sector_costs.h's: 1 + the triangles a sector
// gathers, or an earlier bake's measured times (--costs). The island in 16 shards, each sector's
// time as measured in that run: the costliest shard's sectors took 1.19x the mean split by
// triangles, and would have taken 1.35x split round-robin (i % N, the split before).
// Precondition: count >= 1 (checked).
std::vector<int> shardOwners(std::span<const uint64_t> costs, int count);

// The environment as the shard parser sees it: the value of a variable, or null when unset.
using EnvLookup = std::function<const char*(const char*)>;

// Reads `--shard`: "k/N"; "slurm" (the array task's index and count); "k8s" or "k8s/N" (the
// Indexed Job's JOB_COMPLETION_INDEX, of N or of DRTV_SHARD_COUNT); "auto" or "auto/N" (slurm
// when SLURM_ARRAY_TASK_ID is set, else k8s when JOB_COMPLETION_INDEX is, else an error naming
// both). A count on the command line must agree with Slurm's. Errors (bad input, a usage error
// for the CLI): a missing or malformed variable, named with its value; k outside 0..N-1.
// Thread-safe when `env` is.
Result<ShardSpec> parseShard(std::string_view text, const EnvLookup& env);

// What a shard wrote about itself (shard-<k>-of-<N>.json).
struct ShardStatus {
  enum class State { kRunning, kDone, kFailed };
  int index = 0, count = 1;
  State state = State::kRunning;
  std::string fingerprint;  // the bake's (16 hex digits), "" when the shard failed before knowing it
  std::string world;        // the world's name or file
  std::vector<std::pair<std::string, std::string>> settings;  // BakeSettings::describe()
  size_t sectors = 0;       // sectors this shard owns (shardOwners)
  uint64_t cost = 0;        // their cost, summed (shardOwners' units: sector_costs.h)
  std::string split = "estimated";  // how the bake split its sectors (SectorCosts::split)
  size_t baked = 0;         // of which baked by its last run (the rest were resumed)
  double wall_s = 0;        // its last run, wall seconds (0 while running)
  uint64_t peak_rss_bytes = 0;  // its last run's peak resident memory (0 while running, or unknown)
  std::string host;         // where it ran (gethostname)
  std::string error;        // why it failed (kFailed only)
};
const char* stateName(ShardStatus::State state);  // "running", "done", "failed"

// How even the done shards of a bake ran (issue 36: shards balanced by cost): the slowest against
// the mean of their wall times, and the most memory one held.
struct ShardTime {
  int index = 0;
  double wall_s = 0;
  uint64_t peak_rss_bytes = 0;
};
struct ShardBalance {
  int done = 0, slowest = 0;  // done shards; the slowest's index
  double slowest_s = 0, mean_s = 0;
  uint64_t most_peak = 0;     // the largest peak_rss_bytes
};
// Over the done shards' times; nothing until two are done (or their times sum to 0).
std::optional<ShardBalance> shardBalance(std::span<const ShardTime> done);
// The same over the shards of `statuses` that are done.
std::optional<ShardBalance> shardBalance(std::span<const ShardStatus> statuses);

// "<dir>/shard-<k>-of-<N>.json".
std::filesystem::path shardStatusFile(const std::filesystem::path& dir, int index, int count);
// Writes `status` to its file in `dir` atomically (a temporary file named by host and process,
// then a rename). Errors name the file.
Result<void> writeShardStatus(const std::filesystem::path& dir, const ShardStatus& status);
// Every shard-*-of-*.json in `dir`, ordered by (count, index); none when `dir` does not exist.
// Errors (bad input): a file that is not a shard status, naming it.
Result<std::vector<ShardStatus>> readShardStatuses(const std::filesystem::path& dir);
// Records that shard `spec` of the bake of `archive` failed with `message`: its status file (the
// sector folder created if need be) says failed, keeping what the shard wrote before. A folder
// that cannot be written is an error naming it (the caller still reports `message`).
Result<void> recordShardFailure(const std::filesystem::path& archive, ShardSpec spec, const std::string& message);

// `drtv farm status`: every shard of the bake of `archive`.
struct FarmShard {
  int index = 0;
  // "done", "running", "stopped" (its status says running but no process holds its journal:
  // killed, preempted or lost with its machine; rerun it), "failed", "missing" (no status and no
  // journal).
  std::string state;
  std::string error;     // a failed shard's
  std::string host;
  size_t sectors = 0;    // owned (0 when missing)
  size_t journaled = 0;  // whole records in its journal
  uint64_t cost = 0;     // its sectors' estimated cost (ShardStatus::cost)
  double wall_s = 0;
  uint64_t peak_rss_bytes = 0;  // ShardStatus::peak_rss_bytes
};
struct FarmStatus {
  bool packed = false;        // the archive exists and no sector folder is left
  int count = 0;              // N, from the status files (0 when none)
  std::vector<FarmShard> shards;          // 0 .. N-1
  std::vector<std::string> problems;      // status files of another split or bake
};
// Reads "<archive>.sectors/". Errors: an unreadable folder, status file or journal, naming it.
Result<FarmStatus> farmStatus(const std::filesystem::path& archive);

}  // namespace drtv::baker
