// Scheduler scripts and manifests for a sharded bake (see farm.h).
#include "drtv/baker/farm.h"

#include <algorithm>
#include <cctype>

#include <nlohmann/json.hpp>

#include "drtv/baker/bake.h"
#include "drtv/baker/shard.h"
#include "drtv/raytrace/world_geometry.h"

namespace drtv::baker {
namespace {

constexpr uint64_t kMiB = 1ull << 20;

uint64_t roundUp64MiB(uint64_t bytes) { return (bytes + 64 * kMiB - 1) / (64 * kMiB) * (64 * kMiB); }

std::string megabytes(uint64_t bytes) { return std::to_string((bytes + kMiB - 1) / kMiB); }

// The bake's argv: a shard (`shard_flag`) or the merge, bounded by the memory its task is given
// (--max-memory, memory_limit.h): an input that needs more is refused up front with an error
// naming it, which the shard writes into its status, instead of the scheduler killing the task.
std::vector<std::string> bakeArgv(const FarmPlan& p, const std::string& shard_flag) {
  std::vector<std::string> argv{p.drtv, "bake", p.world, "-o", p.archive};
  if (shard_flag.empty()) {
    argv.insert(argv.end(), {"--merge", "--max-memory", megabytes(p.merge_memory_bytes) + "M"});
  } else {
    argv.insert(argv.end(), {"--shard", shard_flag, "--threads", std::to_string(p.cpus_per_task), "--max-memory",
                             megabytes(p.memory_bytes) + "M"});
  }
  argv.insert(argv.end(), p.bake_args.begin(), p.bake_args.end());
  return argv;
}

std::string bakeCommand(const FarmPlan& p, const std::string& shard_flag) {
  std::string out;
  for (const std::string& a : bakeArgv(p, shard_flag)) out += (out.empty() ? "" : " ") + shellQuote(a);
  return out;
}

nlohmann::ordered_json podSpec(const FarmPlan& p, bool merge, const std::string& container) {
  nlohmann::ordered_json resources;
  const uint64_t memory = merge ? p.merge_memory_bytes : p.memory_bytes;
  resources["requests"] = {{"cpu", std::to_string(merge ? 1 : p.cpus_per_task)}, {"memory", megabytes(memory) + "Mi"}};
  resources["limits"] = {{"memory", megabytes(memory) + "Mi"}};
  nlohmann::ordered_json c;
  c["name"] = container;
  c["image"] = p.image;
  c["command"] = bakeArgv(p, merge ? "" : "k8s/" + std::to_string(p.shards));
  c["env"] = nlohmann::ordered_json::array({{{"name", "CI"}, {"value", "1"}}});  // no progress bars in pod logs
  c["resources"] = resources;
  c["volumeMounts"] = nlohmann::ordered_json::array({{{"name", "bake"}, {"mountPath", p.mount_path}}});
  nlohmann::ordered_json spec;
  spec["restartPolicy"] = "Never";  // backoffLimitPerIndex requires it; a retry is a new pod
  spec["containers"] = nlohmann::ordered_json::array({c});
  spec["volumes"] = nlohmann::ordered_json::array({{{"name", "bake"}, {"persistentVolumeClaim", {{"claimName", p.claim}}}}});
  return spec;
}

nlohmann::ordered_json jobMetadata(const FarmPlan& p, const std::string& name) {
  return {{"name", name}, {"labels", {{"app.kubernetes.io/name", "drtv-bake"}, {"drtv.bake/job", p.job_name}}}};
}

bool isDnsLabel(const std::string& s) {
  if (s.empty() || s.size() > 50 || !std::isalnum(static_cast<unsigned char>(s.front())) || !std::isalnum(static_cast<unsigned char>(s.back())))
    return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-'; });
}

}  // namespace

std::string shellQuote(const std::string& word) {
  const bool plain = !word.empty() && std::all_of(word.begin(), word.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::string_view("/._-+=:,@%").find(c) != std::string_view::npos;
  });
  if (plain) return word;
  std::string out = "'";
  for (const char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

double ShardEstimate::slowestOverMean() const {
  if (shard_units.empty()) return 1.0;
  uint64_t most = 0;
  double sum = 0;
  for (const uint64_t u : shard_units) most = std::max(most, u), sum += double(u);
  return sum > 0 ? double(most) / (sum / double(shard_units.size())) : 1.0;
}

Result<ShardEstimate> estimateShard(const worlds::World& world, const std::string& where, int shards, int max_cpus,
                                   const MeasuredCosts* measured) {
  if (shards < 1) return fail("shards: " + std::to_string(shards) + " must be at least 1");
  if (max_cpus < 1) return fail("cpus: " + std::to_string(max_cpus) + " must be at least 1");
  auto geometry = raytrace::WorldGeometry::build(world, where);
  if (!geometry) return std::unexpected(geometry.error());
  const BakeSettings settings = BakeSettings::forQuality(Quality::kDefault);  // every preset has the same halo
  const double halo_m = haloFor(settings, effectsToBake(world, nullptr));
  ShardEstimate e;
  e.sectors = geometry->sectors().count();
  // The bake's own split (bake.cpp): the most sectors any shard owns.
  const std::vector<SectorKey> keys = bakeKeys(geometry->sectors());
  const SectorCosts estimated = sectorCosts(*geometry, keys, halo_m);
  const SectorCosts costs = measured ? measuredCosts(estimated, keys, geometry->fingerprint(), *measured) : estimated;
  const std::vector<int> owner = shardOwners(costs.units, shards);
  e.split = costs.split;
  e.measured = costs.measured;
  e.seconds_per_unit = costs.seconds_per_unit;
  e.shard_sectors.assign(size_t(shards), 0);
  e.shard_units.assign(size_t(shards), 0);
  for (size_t i = 0; i < keys.size(); ++i) {
    ++e.shard_sectors[size_t(owner[i])];
    e.shard_units[size_t(owner[i])] += costs.units[i];
  }
  e.sectors_per_shard = *std::max_element(e.shard_sectors.begin(), e.shard_sectors.end());
  if (costs.split != "estimated") {
    const std::vector<int> by_triangles = shardOwners(estimated.units, shards);
    std::vector<double> load(size_t(shards), 0.0);
    double sum = 0;
    for (size_t i = 0; i < keys.size(); ++i) load[size_t(by_triangles[i])] += double(costs.units[i]), sum += double(costs.units[i]);
    e.triangle_split_slowest_over_mean = sum > 0 ? *std::max_element(load.begin(), load.end()) / (sum / shards) : 1.0;
  }
  e.largest_gather = geometry->largestGather(geometry->sectors(), halo_m, &e.largest_at);
  for (const worlds::Mesh& m : world.meshes) e.world_bytes += m.positions.size() * sizeof(glm::vec3) + m.indices.size() * sizeof(uint32_t);
  e.cpus = int(std::clamp<size_t>(e.sectors_per_shard, 1, size_t(max_cpus)));
  const uint64_t world_resident = 2 * e.world_bytes;
  e.memory_bytes = roundUp64MiB(kShardBaseBytes + world_resident +
                                uint64_t(e.cpus) * e.largest_gather * raytrace::WorldGeometry::kBakeBytesPerGatheredTriangle);
  e.merge_memory_bytes = roundUp64MiB(kShardBaseBytes + world_resident);
  return e;
}

Result<void> validatePlan(const FarmPlan& p, bool kubernetes) {
  if (p.shards < 2) return fail("--shards " + std::to_string(p.shards) + ": a farm bake has at least 2 shards (one is a plain `drtv bake`)");
  if (p.shards > 100000) return fail("--shards " + std::to_string(p.shards) + ": at most 100000");
  if (p.cpus_per_task < 1) return fail("--cpus " + std::to_string(p.cpus_per_task) + ": must be at least 1");
  if (!isDnsLabel(p.job_name)) return fail("--name '" + p.job_name + "': lower-case letters, digits and '-', 1 to 50, no '-' at either end");
  if (p.world.empty() || p.archive.empty()) return fail("the world and the archive are needed");
  if (kubernetes) {
    if (p.image.empty()) return fail("--image: the container image with drtv is needed");
    if (p.claim.empty()) return fail("--claim: the PersistentVolumeClaim holding the world and the archive is needed");
    if (p.parallelism < 0) return fail("--parallelism " + std::to_string(p.parallelism) + ": must be >= 0");
    if (p.backoff_per_index < 0) return fail("--backoff-per-index " + std::to_string(p.backoff_per_index) + ": must be >= 0");
  }
  return {};
}

std::string slurmShardScript(const FarmPlan& p) {
  std::string s = "#!/bin/bash\n";
  s += "# The shards of the bake of " + p.world + " into " + p.archive + " (written by `drtv farm slurm`).\n";
  s += "# A task that fails or is requeued resumes from its journal in " + p.archive + ".sectors/.\n";
  s += "#SBATCH --job-name=" + p.job_name + "\n";
  s += "#SBATCH --array=0-" + std::to_string(p.shards - 1) + "\n";
  s += "#SBATCH --ntasks=1\n";
  s += "#SBATCH --cpus-per-task=" + std::to_string(p.cpus_per_task) + "\n";
  s += "#SBATCH --mem=" + megabytes(p.memory_bytes) + "M\n";
  if (!p.partition.empty()) s += "#SBATCH --partition=" + p.partition + "\n";
  if (!p.time_limit.empty()) s += "#SBATCH --time=" + p.time_limit + "\n";
  s += "#SBATCH --output=" + p.log_dir + "/%A_%a.log\n";
  // A requeued task would truncate its log (and the first attempt's error with it).
  s += "#SBATCH --open-mode=append\n";
  s += "#SBATCH --requeue\n";
  s += "set -euo pipefail\n";
  s += "export CI=1  # no progress bar in the log\n";
  s += "echo \"drtv: shard ${SLURM_ARRAY_TASK_ID} of " + std::to_string(p.shards) +
       " on $(hostname), restart ${SLURM_RESTART_COUNT:-0}\"\n";
  s += "exec " + bakeCommand(p, "slurm") + "\n";
  return s;
}

std::string slurmMergeScript(const FarmPlan& p) {
  std::string s = "#!/bin/bash\n";
  s += "# Packs what the " + std::to_string(p.shards) + " shards baked into " + p.archive +
       " (written by `drtv farm slurm`; submit.sh runs it after every shard).\n";
  s += "#SBATCH --job-name=" + p.job_name + "-merge\n";
  s += "#SBATCH --ntasks=1\n";
  s += "#SBATCH --cpus-per-task=1\n";
  s += "#SBATCH --mem=" + megabytes(p.merge_memory_bytes) + "M\n";
  if (!p.partition.empty()) s += "#SBATCH --partition=" + p.partition + "\n";
  if (!p.time_limit.empty()) s += "#SBATCH --time=" + p.time_limit + "\n";
  s += "#SBATCH --output=" + p.log_dir + "/%j-merge.log\n";
  s += "#SBATCH --open-mode=append\n";
  s += "set -euo pipefail\n";
  s += "export CI=1\n";
  s += "exec " + bakeCommand(p, "") + "\n";
  return s;
}

std::string slurmSubmitScript(const FarmPlan& p) {
  std::string s = "#!/bin/bash\n";
  s += "# Submits the shards, then the merge after each shard task succeeded (a per-task afterok list;\n";
  s += "# after a failed task, retry.sh requeues it and sets the merge's dependency again).\n";
  s += "set -euo pipefail\n";
  s += "here=$(cd \"$(dirname \"$0\")\" && pwd)\n";
  s += "mkdir -p " + shellQuote(p.log_dir) + "\n";
  s += "array=$(sbatch --parsable \"$here/shards.sbatch\")\n";
  s += "array=${array%%;*}  # --parsable prints id[;cluster]\n";
  s += "deps=\"\"\n";
  s += "for ((i = 0; i < " + std::to_string(p.shards) + "; ++i)); do deps=\"$deps:${array}_$i\"; done\n";
  s += "merge=$(sbatch --parsable --dependency=\"afterok$deps\" \"$here/merge.sbatch\")\n";
  s += "merge=${merge%%;*}\n";
  s += "printf 'array=%s\\nmerge=%s\\n' \"$array\" \"$merge\" >\"$here/jobs.env\"  # for retry.sh\n";
  s += "echo \"shards $array\"\n";
  s += "echo \"merge $merge\"\n";
  return s;
}

std::string slurmRetryScript(const FarmPlan& p) {
  std::string s = "#!/bin/bash\n";
  s += "# Retries failed shard tasks of the array submit.sh submitted (each resumes from its journal)\n";
  s += "# and re-arms the merge: Slurm does not test again a dependency it has found never satisfied.\n";
  s += "# usage: retry.sh <task index>...\n";
  s += "set -euo pipefail\n";
  s += "here=$(cd \"$(dirname \"$0\")\" && pwd)\n";
  s += "[ $# -gt 0 ] || { echo \"usage: $0 <task index>...\" >&2; exit 2; }\n";
  s += "source \"$here/jobs.env\"  # array=, merge=\n";
  s += "for task in \"$@\"; do\n";
  s += "  scontrol requeue \"${array}_$task\"\n";
  s += "  scontrol update JobId=\"${array}_$task\" StartTime=now  # else it waits out the credential's lifetime\n";
  s += "done\n";
  s += "deps=\"\"\n";
  s += "for ((i = 0; i < " + std::to_string(p.shards) + "; ++i)); do deps=\"$deps:${array}_$i\"; done\n";
  s += "scontrol update JobId=\"$merge\" Dependency=\"afterok$deps\"\n";
  s += "echo \"retried ${array}_{$*}; merge $merge waits for them again\"\n";
  return s;
}

std::string kubernetesShardJob(const FarmPlan& p) {
  nlohmann::ordered_json job;
  job["apiVersion"] = "batch/v1";
  job["kind"] = "Job";
  job["metadata"] = jobMetadata(p, p.job_name + "-shards");
  nlohmann::ordered_json spec;
  spec["completionMode"] = "Indexed";  // JOB_COMPLETION_INDEX = the shard
  spec["completions"] = p.shards;
  spec["parallelism"] = p.parallelism > 0 ? std::min(p.parallelism, p.shards) : p.shards;
  spec["backoffLimitPerIndex"] = p.backoff_per_index;  // Kubernetes 1.29+: a failing shard does not stop the others
  spec["template"] = {{"metadata", {{"labels", {{"app.kubernetes.io/name", "drtv-bake"}}}}}, {"spec", podSpec(p, false, "shard")}};
  job["spec"] = spec;
  return job.dump(2) + "\n";
}

std::string kubernetesMergeJob(const FarmPlan& p) {
  nlohmann::ordered_json job;
  job["apiVersion"] = "batch/v1";
  job["kind"] = "Job";
  job["metadata"] = jobMetadata(p, p.job_name + "-merge");
  nlohmann::ordered_json spec;
  spec["completions"] = 1;
  spec["backoffLimit"] = p.backoff_per_index;
  spec["template"] = {{"metadata", {{"labels", {{"app.kubernetes.io/name", "drtv-bake"}}}}}, {"spec", podSpec(p, true, "merge")}};
  job["spec"] = spec;
  return job.dump(2) + "\n";
}

std::string kubernetesSubmitScript(const FarmPlan& p) {
  std::string s = "#!/bin/bash\n";
  s += "# Applies the shard Job, waits until every index completed, then applies the merge Job.\n";
  s += "# A shard that failed all its retries leaves the Job Failed: the wait stops and says so.\n";
  s += "set -euo pipefail\n";
  s += "here=$(cd \"$(dirname \"$0\")\" && pwd)\n";
  s += "kubectl apply -f \"$here/shards-job.json\"\n";
  s += "until kubectl wait --for=condition=complete --timeout=60s job/" + p.job_name + "-shards 2>/dev/null; do\n";
  s += "  if kubectl wait --for=condition=failed --timeout=1s job/" + p.job_name + "-shards 2>/dev/null; then\n";
  s += "    echo \"shard job " + p.job_name + "-shards failed; see drtv farm status " + p.archive + "\" >&2; exit 1\n";
  s += "  fi\n";
  s += "done\n";
  s += "kubectl apply -f \"$here/merge-job.json\"\n";
  s += "kubectl wait --for=condition=complete --timeout=24h job/" + p.job_name + "-merge\n";
  return s;
}

}  // namespace drtv::baker
