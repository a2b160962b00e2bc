// drtv farm slurm <world> -o <archive> --shards N --scripts DIR [--submit] ...
// drtv farm k8s   <world> -o <archive> --shards N --scripts DIR --image I --claim C ...
// drtv farm status <archive> [--json]
// drtv farm plan  <world> --shards N [--costs bake-report.json] [--json]
// Writes the jobs of a sharded bake for an existing scheduler (drtv/baker/farm.h), and reads what
// the shards left behind (drtv/baker/shard.h). docs/baker.md, "Baking on a farm".
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <vector>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "drtv/baker/farm.h"
#include "drtv/baker/shard.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/load.h"

namespace drtv::app {
namespace {
namespace fs = std::filesystem;

struct FarmCliOptions {
  std::string world, archive, scripts;
  int shards = 0;
  int max_cpus = 8;
  int mem_mb = 0;  // 0 = estimated
  std::string quality, seed;
  std::string costs;  // an earlier bake's report (sector_costs.h)
  std::vector<std::string> bake_args;
  std::string name = "drtv-bake";
  // Slurm
  std::string partition, time_limit, log_dir, drtv;
  bool submit = false;
  // Kubernetes
  std::string image, claim, mount_path = "/bake", volume_root = ".";
  int parallelism = 0, backoff_per_index = 2;
  // status
  bool json = false;
};

Result<void> writeText(const fs::path& file, const std::string& text, bool executable) {
  std::ofstream f(file, std::ios::binary | std::ios::trunc);
  if (!f) return fail(file.string() + ": cannot open for writing");
  f << text;
  f.close();
  if (!f) return fail(file.string() + ": write failed");
  if (executable && ::chmod(file.c_str(), 0755) != 0) return fail(file.string() + ": cannot make it executable");
  return {};
}

fs::path absolute(const std::string& p) { return fs::absolute(fs::path(p)).lexically_normal(); }

// The estimate from the world (and --costs).
// `read`, when given, receives the --costs report as read (its measured memory: runPlan).
Result<baker::ShardEstimate> estimateFor(const FarmCliOptions& o, std::optional<baker::MeasuredCosts>* read = nullptr) {
  std::optional<baker::MeasuredCosts> own;
  std::optional<baker::MeasuredCosts>& costs = read ? *read : own;
  if (!o.costs.empty()) {
    auto c = baker::readMeasuredCosts(o.costs);
    if (!c) return std::unexpected(c.error());
    costs = std::move(*c);
  }
  auto world = worlds::loadWorld(o.world);
  if (!world) return std::unexpected(world.error());
  return baker::estimateShard(*world, o.world, o.shards, o.max_cpus, costs ? &*costs : nullptr);
}

// How the sectors split, in one line.
std::string splitLine(const FarmCliOptions& o, const baker::ShardEstimate& e) {
  if (e.split != "estimated")
    return "split by the times " + o.costs + " measured (" + std::to_string(e.measured) + " of " + std::to_string(e.sectors) +
           " sectors; the rest by their triangles at its rate)";
  if (e.seconds_per_unit > 0) return "split by triangles gathered; " + o.costs + " measured another world, so only its rate predicts the times";
  return "split by triangles gathered (--costs an earlier bake's report to split by time)";
}

// The plan both schedulers share: the estimate from the world, the bake's own flags.
Result<baker::FarmPlan> planFor(const FarmCliOptions& o, bool kubernetes) {
  auto estimate = estimateFor(o);
  if (!estimate) return std::unexpected(estimate.error());
  baker::FarmPlan plan;
  plan.shards = o.shards;
  plan.job_name = o.name;
  plan.cpus_per_task = estimate->cpus;
  plan.memory_bytes = o.mem_mb > 0 ? uint64_t(o.mem_mb) << 20 : estimate->memory_bytes;
  plan.merge_memory_bytes = estimate->merge_memory_bytes;
  if (!o.quality.empty()) plan.bake_args.insert(plan.bake_args.end(), {"--quality", o.quality});
  if (!o.seed.empty()) plan.bake_args.insert(plan.bake_args.end(), {"--seed", o.seed});
  plan.bake_args.insert(plan.bake_args.end(), o.bake_args.begin(), o.bake_args.end());
  std::printf("%s; the costliest shard %.2fx the mean\n", splitLine(o, *estimate).c_str(), estimate->slowestOverMean());
  std::printf("%s: %zu sectors, %zu per shard at most; the largest gather %llu triangles (sector %s); per task %d CPUs, %llu MiB%s\n",
              o.world.c_str(), estimate->sectors, estimate->sectors_per_shard,
              static_cast<unsigned long long>(estimate->largest_gather), toString(estimate->largest_at).c_str(), plan.cpus_per_task,
              static_cast<unsigned long long>(plan.memory_bytes >> 20), o.mem_mb > 0 ? " (--mem)" : " (estimated)");
  if (kubernetes) {
    // In the pods the claim's root is mount_path; here it is --volume-root.
    const fs::path root = absolute(o.volume_root);
    auto inPod = [&](const std::string& local, const char* what) -> Result<std::string> {
      const fs::path rel = absolute(local).lexically_relative(root);
      if (rel.empty() || *rel.begin() == "..")
        return fail(local + ": the " + std::string(what) + " must lie under --volume-root " + root.string() +
                    " (the claim's contents as seen here)");
      return (fs::path(o.mount_path) / rel).string();
    };
    auto w = inPod(o.world, "world");
    if (!w) return std::unexpected(w.error());
    auto a = inPod(o.archive, "archive");
    if (!a) return std::unexpected(a.error());
    plan.world = *w;
    plan.archive = *a;
    if (!o.costs.empty()) {
      auto c = inPod(o.costs, "--costs report");
      if (!c) return std::unexpected(c.error());
      plan.bake_args.insert(plan.bake_args.end(), {"--costs", *c});
    }
    plan.drtv = o.drtv.empty() ? "drtv" : o.drtv;
    plan.image = o.image;
    plan.claim = o.claim;
    plan.mount_path = o.mount_path;
    plan.parallelism = o.parallelism;
    plan.backoff_per_index = o.backoff_per_index;
  } else {
    plan.world = absolute(o.world).string();
    plan.archive = absolute(o.archive).string();
    if (!o.costs.empty()) plan.bake_args.insert(plan.bake_args.end(), {"--costs", absolute(o.costs).string()});
    plan.log_dir = absolute(o.log_dir.empty() ? (fs::path(o.scripts) / "logs").string() : o.log_dir).string();
    std::error_code ec;
    plan.drtv = o.drtv.empty() ? fs::read_symlink("/proc/self/exe", ec).string() : absolute(o.drtv).string();
    if (ec || plan.drtv.empty()) plan.drtv = "drtv";
    plan.partition = o.partition;
    plan.time_limit = o.time_limit;
  }
  if (auto why = baker::validatePlan(plan, kubernetes); !why) return fail(why.error().message);
  return plan;
}

Result<void> runSlurm(const FarmCliOptions& o) {
  auto plan = planFor(o, false);
  if (!plan) return std::unexpected(plan.error());
  const fs::path dir(o.scripts);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  fs::create_directories(plan->log_dir, ec);
  if (ec) return fail(plan->log_dir + ": cannot create the log folder: " + ec.message());
  if (auto w = writeText(dir / "shards.sbatch", baker::slurmShardScript(*plan), true); !w) return w;
  if (auto w = writeText(dir / "merge.sbatch", baker::slurmMergeScript(*plan), true); !w) return w;
  if (auto w = writeText(dir / "submit.sh", baker::slurmSubmitScript(*plan), true); !w) return w;
  if (auto w = writeText(dir / "retry.sh", baker::slurmRetryScript(*plan), true); !w) return w;
  std::printf("wrote %s/{shards.sbatch,merge.sbatch,submit.sh,retry.sh}; logs go to %s\n", dir.string().c_str(), plan->log_dir.c_str());
  if (!o.submit) {
    std::printf("submit with: %s/submit.sh\n", dir.string().c_str());
    return {};
  }
  std::fflush(stdout);
  const std::string cmd = "bash " + baker::shellQuote((dir / "submit.sh").string());
  const int st = std::system(cmd.c_str());
  if (!WIFEXITED(st) || WEXITSTATUS(st) != 0)
    return fail((dir / "submit.sh").string() + ": submitting failed (exit " + std::to_string(WIFEXITED(st) ? WEXITSTATUS(st) : -1) +
                "; is sbatch on the PATH and the cluster up?)");
  return {};
}

Result<void> runKubernetes(const FarmCliOptions& o) {
  auto plan = planFor(o, true);
  if (!plan) return std::unexpected(plan.error());
  const fs::path dir(o.scripts);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  if (auto w = writeText(dir / "shards-job.json", baker::kubernetesShardJob(*plan), false); !w) return w;
  if (auto w = writeText(dir / "merge-job.json", baker::kubernetesMergeJob(*plan), false); !w) return w;
  if (auto w = writeText(dir / "submit.sh", baker::kubernetesSubmitScript(*plan), true); !w) return w;
  std::printf("wrote %s/{shards-job.json,merge-job.json,submit.sh}\nsubmit with: %s/submit.sh\n", dir.string().c_str(),
              dir.string().c_str());
  return {};
}

// The slowest done shard against the mean of the done shards' wall times (baker::shardBalance).
std::optional<baker::ShardBalance> balance(const baker::FarmStatus& status) {
  std::vector<baker::ShardTime> done;
  for (const baker::FarmShard& s : status.shards)
    if (s.state == "done") done.push_back({s.index, s.wall_s, s.peak_rss_bytes});
  return baker::shardBalance(std::span<const baker::ShardTime>(done));
}

Result<void> runStatus(const FarmCliOptions& o) {
  auto status = baker::farmStatus(o.archive);
  if (!status) return std::unexpected(status.error());
  if (o.json) {
    nlohmann::ordered_json j;
    j["archive"] = o.archive;
    j["packed"] = status->packed;
    j["shards"] = status->count;
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const baker::FarmShard& s : status->shards) {
      nlohmann::ordered_json e{{"shard", s.index}, {"state", s.state}, {"sectors", s.sectors}, {"journaled", s.journaled},
                               {"cost", s.cost}, {"wall_s", s.wall_s}, {"peak_rss_bytes", s.peak_rss_bytes},
                               {"host", s.host}};
      if (!s.error.empty()) e["error"] = s.error;
      list.push_back(e);
    }
    j["list"] = list;
    if (const auto b = balance(*status)) j["balance"] = {{"slowest", b->slowest}, {"slowest_s", b->slowest_s}, {"mean_s", b->mean_s},
                                                          {"slowest_over_mean", b->slowest_s / b->mean_s}, {"done", b->done}};
    j["problems"] = status->problems;
    std::printf("%s\n", j.dump(2).c_str());
    return {};
  }
  if (status->packed) {
    std::printf("%s: packed (no sector folder left)\n", o.archive.c_str());
    return {};
  }
  std::map<std::string, int> counts;
  for (const baker::FarmShard& s : status->shards) ++counts[s.state];
  std::printf("%s: %d shards: %d done, %d running, %d stopped, %d failed, %d missing\n", o.archive.c_str(), status->count,
              counts["done"], counts["running"], counts["stopped"], counts["failed"], counts["missing"]);
  for (const baker::FarmShard& s : status->shards) {
    std::printf("shard %d/%d %-8s %zu/%zu sectors journaled", s.index, status->count, s.state.c_str(), s.journaled, s.sectors);
    if (s.state == "done") std::printf(", %.1f s", s.wall_s);
    if (s.state == "done" && s.peak_rss_bytes) std::printf(", peak %s resident", formatBytes(s.peak_rss_bytes).c_str());
    if (!s.host.empty()) std::printf(", on %s", s.host.c_str());
    if (!s.error.empty()) std::printf(": %s", s.error.c_str());
    if (s.state == "stopped") std::printf(": no process holds its journal (killed or lost); rerun it");
    std::printf("\n");
  }
  if (const auto b = balance(*status))
    std::printf("balance: the slowest of %d done shards, %d, took %.1f s: %.2fx their mean %.1f s\n", b->done, b->slowest,
                b->slowest_s, b->slowest_s / b->mean_s, b->mean_s);
  for (const std::string& p : status->problems) std::printf("problem: %s\n", p.c_str());
  return {};
}

// `drtv farm plan`: the split every shard would compute, shard by shard, and with --costs the
// time each would take (sector_costs.h): to choose N, or to project a larger world from a
// smaller one's measured rate.
Result<void> runPlan(const FarmCliOptions& o) {
  std::optional<baker::MeasuredCosts> costs;
  auto e = estimateFor(o, &costs);
  if (!e) return std::unexpected(e.error());
  const bool timed = e->seconds_per_unit > 0;
  double sum_s = 0, most_s = 0;
  for (int k = 0; k < o.shards; ++k) sum_s += e->shardSeconds(k), most_s = std::max(most_s, e->shardSeconds(k));
  if (o.json) {
    nlohmann::ordered_json j;
    j["world"] = o.world;
    j["sectors"] = e->sectors;
    j["shards"] = o.shards;
    j["split"] = e->split;
    j["measured_sectors"] = e->measured;
    j["cpus_per_task"] = e->cpus;
    j["memory_mib"] = e->memory_bytes >> 20;
    j["slowest_over_mean"] = e->slowestOverMean();
    if (e->triangle_split_slowest_over_mean > 0) j["triangle_split_slowest_over_mean"] = e->triangle_split_slowest_over_mean;
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (int k = 0; k < o.shards; ++k) {
      nlohmann::ordered_json s{{"shard", k}, {"sectors", e->shard_sectors[size_t(k)]}, {"cost", e->shard_units[size_t(k)]}};
      if (timed) s["predicted_s"] = e->shardSeconds(k);
      list.push_back(s);
    }
    j["list"] = list;
    if (timed) j["predicted"] = {{"sum_s", sum_s}, {"slowest_s", most_s}, {"slowest_wall_s", most_s / e->cpus}};
    if (costs && (costs->peak_bytes || costs->shard_peak_bytes))
      j["measured_memory"] = {{"peak_bytes", costs->peak_bytes}, {"shard_peak_bytes", costs->shard_peak_bytes}, {"shards", costs->shards}};
    std::printf("%s\n", j.dump(2).c_str());
    return {};
  }
  std::printf("%s: %zu sectors in %d shards; %s\n", o.world.c_str(), e->sectors, o.shards, splitLine(o, *e).c_str());
  std::printf("%-8s %8s %16s%s\n", "shard", "sectors", "cost", timed ? "  predicted s (sum of its sectors')" : "");
  for (int k = 0; k < o.shards; ++k) {
    std::printf("%-8s %8zu %16llu", (std::to_string(k) + "/" + std::to_string(o.shards)).c_str(), e->shard_sectors[size_t(k)],
                static_cast<unsigned long long>(e->shard_units[size_t(k)]));
    if (timed) std::printf("  %.1f", e->shardSeconds(k));
    std::printf("\n");
  }
  std::printf("the costliest shard: %.3fx the mean", e->slowestOverMean());
  if (e->triangle_split_slowest_over_mean > 0)
    std::printf(" (split by triangles, by the same times: %.3fx)", e->triangle_split_slowest_over_mean);
  std::printf("\n");
  if (timed)
    std::printf("predicted: %.1f s of sector time in all; the slowest shard %.1f s, about %.1f s of wall time on its task's %d CPUs "
                "(%llu MiB a task), plus loading the world\n",
                sum_s, most_s, most_s / e->cpus, e->cpus, static_cast<unsigned long long>(e->memory_bytes >> 20));
  if (costs && costs->shard_peak_bytes)
    std::printf("measured: the report's %d shards held %s resident at most (its merge %s); this plan asks %llu MiB a task\n",
                costs->shards, formatBytes(costs->shard_peak_bytes).c_str(), formatBytes(costs->peak_bytes).c_str(),
                static_cast<unsigned long long>(e->memory_bytes >> 20));
  else if (costs && costs->peak_bytes)
    std::printf("measured: the report's bake held %s resident at most; this plan asks %llu MiB a task\n",
                formatBytes(costs->peak_bytes).c_str(), static_cast<unsigned long long>(e->memory_bytes >> 20));
  return {};
}

void addPlanOptions(CLI::App* sub, FarmCliOptions& o) {
  sub->add_option("world", o.world, "World file (.json, .gltf, .glb), read here for the estimate")->required();
  sub->add_option("-o,--output", o.archive, "Archive the merge writes; shard journals go to <archive>.sectors/")->required();
  sub->add_option("--shards", o.shards, "Number of shards N (at least 2)")->required()->check(CLI::Range(2, 100000));
  sub->add_option("--scripts", o.scripts, "Folder to write the job files into")->required();
  sub->add_option("--max-cpus", o.max_cpus, "Most CPUs per shard task (default 8; the estimate gives each sector a core)")
      ->check(CLI::Range(1, 1024));
  sub->add_option("--mem", o.mem_mb, "Memory per shard task in MiB (default: estimated from the world)")->check(CLI::Range(1, 1 << 24));
  sub->add_option("--quality", o.quality, "draft | default | high, passed to every shard and the merge")
      ->check(CLI::IsMember({"draft", "default", "high"}));
  sub->add_option("--seed", o.seed, "Seed, passed to every shard and the merge");
  sub->add_option("--costs", o.costs,
                  "An earlier bake's bake-report.json of this world: split the shards by its measured sector times (passed to every "
                  "shard and the merge)")
      ->type_name("REPORT");
  sub->add_option("--bake-arg", o.bake_args, "Another `drtv bake` argument for every shard and the merge (repeat it)")
      ->allow_extra_args(false);
  sub->add_option("--name", o.name, "Job name (Slurm) / name prefix (Kubernetes); default drtv-bake");
}

}  // namespace

Command registerFarm(CLI::App& app) {
  auto o = std::make_shared<FarmCliOptions>();
  CLI::App* farm = app.add_subcommand(
      "farm", "Bake on a cluster: write a Slurm job array or Kubernetes Indexed Job of shards and their merge; show the shards' status");
  farm->require_subcommand(1);
  CLI::App* slurm = farm->add_subcommand(
      "slurm", "Write shards.sbatch (an array of N shard tasks), merge.sbatch, submit.sh (the merge waits on afterok of every task) "
      "and retry.sh (requeue failed tasks, re-arm the merge)");
  addPlanOptions(slurm, *o);
  slurm->add_option("--partition", o->partition, "Slurm partition (default: the cluster's)");
  slurm->add_option("--time", o->time_limit, "Time limit per task, e.g. 02:00:00 (default: the partition's)");
  slurm->add_option("--log-dir", o->log_dir, "Folder of the per-task logs %A_%a.log (default <scripts>/logs)");
  slurm->add_option("--drtv", o->drtv, "The drtv program as the nodes see it (default: this one's absolute path)");
  slurm->add_flag("--submit", o->submit, "Run submit.sh: sbatch the array and the merge, print their job ids");
  CLI::App* plan = farm->add_subcommand(
      "plan", "Print how N shards would split a world's sectors (by their triangles, or by an earlier bake's measured times with "
      "--costs) and, with --costs, each shard's predicted time; a report of another world projects by its rate");
  plan->add_option("world", o->world, "World file (.json, .gltf, .glb)")->required();
  plan->add_option("--shards", o->shards, "Number of shards N")->required()->check(CLI::Range(1, 100000));
  plan->add_option("--costs", o->costs, "An earlier bake's bake-report.json (this world's: its times; another's: its rate)")
      ->type_name("REPORT");
  plan->add_option("--max-cpus", o->max_cpus, "Most CPUs per shard task (default 8)")->check(CLI::Range(1, 1024));
  plan->add_flag("--json", o->json, "Print JSON");
  CLI::App* k8s = farm->add_subcommand(
      "k8s", "Write shards-job.json (an Indexed Job), merge-job.json and submit.sh (kubectl apply, wait, apply the merge)");
  addPlanOptions(k8s, *o);
  k8s->add_option("--image", o->image, "Container image with drtv on its PATH")->required();
  k8s->add_option("--claim", o->claim, "PersistentVolumeClaim holding the world and the archive (ReadWriteMany)")->required();
  k8s->add_option("--mount-path", o->mount_path, "Where the pods mount the claim (default /bake)");
  k8s->add_option("--volume-root", o->volume_root, "The claim's contents as seen here: world and archive lie under it (default .)");
  k8s->add_option("--parallelism", o->parallelism, "Pods at once (default N)")->check(CLI::Range(0, 100000));
  k8s->add_option("--backoff-per-index", o->backoff_per_index, "Retries of each shard before it counts as failed (default 2)")
      ->check(CLI::Range(0, 1000));
  k8s->add_option("--drtv", o->drtv, "The drtv program in the image (default drtv)");
  CLI::App* status = farm->add_subcommand(
      "status", "List the shards of a bake: done, running (journal present, not complete), failed (with the error the shard wrote) and missing");
  status->add_option("archive", o->archive, "The archive the shards bake (its <archive>.sectors/ folder is read)")->required();
  status->add_flag("--json", o->json, "Print JSON instead of lines");
  return {farm,
          [o, slurm, k8s, plan, status]() -> Result<void> {
            if (slurm->parsed()) return runSlurm(*o);
            if (k8s->parsed()) return runKubernetes(*o);
            if (plan->parsed()) return runPlan(*o);
            if (status->parsed()) return runStatus(*o);
            return fail("farm: expected slurm, k8s, plan or status");
          },
          &o->world};
}

}  // namespace drtv::app
