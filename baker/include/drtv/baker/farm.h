// drtv/baker/farm.h — a bake as jobs for an existing scheduler (DESIGN.md, "Beyond one machine"):
// a Slurm job array of N shards and a merge job that waits for every one of them, or a
// Kubernetes Indexed Job and a merge Job. drtv never schedules anything itself; these functions
// only write the text the scheduler reads (docs/baker.md, "Baking on a farm").
//
// Why the merge waits on a list of tasks, `--dependency=afterok:<A>_0:<A>_1:...`, not on
// `afterok:<A>`: each task is a dependency of its own, satisfied by that task's success whether
// first time or on a retry. Slurm (22.05, measured by tests/cli/slurm_farm_test.sh) does not test
// a dependency again once a task of it failed: the merge stayed pending after the retried task
// completed until its dependency was set again, which retry.sh does.
//
// Kubernetes has no dependency between Jobs: the merge Job is applied once the shard Job reports
// Complete (`kubectl wait --for=condition=complete`), which the submit script does.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "drtv/baker/sector_costs.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/worlds/world.h"

namespace drtv::baker {

// What one shard needs, estimated from the world before any shard runs.
struct ShardEstimate {
  size_t sectors = 0;            // of the whole bake
  size_t sectors_per_shard = 0;  // the most any shard owns (shardOwners)
  uint64_t largest_gather = 0;   // triangles the largest sector gathers with its halo
  SectorKey largest_at{};        // which sector that is
  uint64_t world_bytes = 0;      // the world's meshes as loaded (positions and indices)
  int cpus = 1;                  // per task: one sector per core, at most max_cpus
  uint64_t memory_bytes = 0;     // per task: see kShardBaseBytes
  uint64_t merge_memory_bytes = 0;  // the merge: the world and its binning, no sector's scene
  // The split (sector_costs.h) shard by shard, as every shard will compute it.
  std::string split = "estimated";     // SectorCosts::split
  size_t measured = 0;                 // sectors with a time of their own from the report
  double seconds_per_unit = 0;         // 0 without a report: then no time is predicted
  std::vector<size_t> shard_sectors;   // per shard
  std::vector<uint64_t> shard_units;   // per shard: its sectors' cost summed
  // Predicted seconds of shard k: the sum of its sectors' times (about its CPU time; on `cpus`
  // cores about this / cpus), 0 without a report.
  double shardSeconds(int k) const { return double(shard_units[size_t(k)]) * seconds_per_unit; }
  // The costliest shard against the mean of all (1 = even).
  double slowestOverMean() const;
  // Split by measured times: the costliest shard of the triangles' split, timed by the same
  // measured times, against the mean (what --costs gains); 0 otherwise.
  double triangle_split_slowest_over_mean = 0;
};

// The floor of a shard's memory: the program, TBB's arenas, Embree's and the archive's buffers,
// the journals' records. Measured peak RSS (2026-12-04, --threads 2): a draft shard of
// worlds/fc3_testbox.json 46 MiB; default shards of worlds/island.json 2 or 4 ways 76-82 MiB, its
// merge 53 MiB, its whole bake 141 MiB. The floor is ~3x the shards' peak: more threads keep
// more per-thread scratch, and main() keeps freed blocks up to 32 MB in the heap.
inline constexpr uint64_t kShardBaseBytes = 256ull << 20;

// Estimates a shard of an N-way split of `world` (quality draft/default/high share the halo; LPRT
// widens it), the sectors split by their estimated costs or by `measured` (sector_costs.h): cpus = min(max_cpus, sectors_per_shard); memory = kShardBaseBytes + 2 x world_bytes
// (the world as loaded and as binned) + cpus x largest_gather x
// WorldGeometry::kBakeBytesPerGatheredTriangle (each core bakes one sector at a time), rounded up
// to 64 MiB. Errors: the world's (bad geometry), naming `where`; shards < 1 or max_cpus < 1.
Result<ShardEstimate> estimateShard(const worlds::World& world, const std::string& where, int shards, int max_cpus,
                                   const MeasuredCosts* measured = nullptr);

// Everything the scripts and manifests say. Paths are as the machines that run the jobs see them.
struct FarmPlan {
  std::string drtv = "drtv";            // the program
  std::string world;                    // the world file
  std::string archive;                  // the archive to write; its sector folder is beside it
  std::vector<std::string> bake_args;   // passed to every shard and to the merge (--quality draft)
  int shards = 2;                       // N
  int cpus_per_task = 1;                // also each shard's --threads
  uint64_t memory_bytes = 1ull << 30;   // per shard task
  uint64_t merge_memory_bytes = 1ull << 30;
  std::string job_name = "drtv-bake";   // Slurm job name / Kubernetes name prefix (a DNS label)
  // Slurm
  std::string log_dir;                  // %A_%a.log per task, %j.log for the merge
  std::string partition;                // "" = the cluster's default
  std::string time_limit;               // "" = the partition's default, else e.g. "02:00:00"
  // Kubernetes
  std::string image;                    // an image with drtv on its PATH
  std::string claim;                    // the PersistentVolumeClaim holding world and archive
  std::string mount_path = "/bake";     // where the claim is mounted in every pod
  int parallelism = 0;                  // pods at once; 0 = N
  int backoff_per_index = 2;            // retries of each index before it counts as failed
};

// What is wrong with a plan (a usage error), as an error; nothing when it is sound: N >= 2, cpus >= 1, a job name that is a DNS
// label, Kubernetes fields when `kubernetes`.
Result<void> validatePlan(const FarmPlan& plan, bool kubernetes);

// The files of a Slurm bake, in `folder`:
//   shards.sbatch  the array (#SBATCH --array=0-<N-1>, --open-mode=append, <log_dir>/%A_%a.log)
//   merge.sbatch   the merge (`drtv bake --merge`)
//   submit.sh      sbatch the array, then the merge with --dependency=afterok:<A>_0:...:<A>_<N-1>;
//                  prints "shards <A>" and "merge <M>", and keeps both in jobs.env
//   retry.sh       requeues the failed tasks it is given (at once: StartTime=now) and sets the
//                  merge's dependency again (Slurm does not test a dependency again once it has
//                  found it never satisfied; measured with Slurm 22.05, tests/cli/slurm_farm_test.sh)
std::string slurmShardScript(const FarmPlan& plan);
std::string slurmMergeScript(const FarmPlan& plan);
std::string slurmSubmitScript(const FarmPlan& plan);
std::string slurmRetryScript(const FarmPlan& plan);

// The files of a Kubernetes bake (JSON, which kubectl reads as it reads YAML):
//   shards-job.json  an Indexed Job (completionMode Indexed, completions N, parallelism,
//                    backoffLimitPerIndex, restartPolicy Never, the claim mounted at mount_path)
//   merge-job.json   the merge Job (completions 1) on the same claim
//   submit.sh        kubectl apply the shards, wait for Complete, apply the merge
std::string kubernetesShardJob(const FarmPlan& plan);
std::string kubernetesMergeJob(const FarmPlan& plan);
std::string kubernetesSubmitScript(const FarmPlan& plan);

// A word for a POSIX shell, single-quoted when it needs to be.
std::string shellQuote(const std::string& word);

}  // namespace drtv::baker
