// Shards as a scheduler runs them (see shard.h).
#include "drtv/baker/shard.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <fstream>
#include <map>
#include <queue>
#include <sstream>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>

#include "drtv/baker/bake.h"
#include "atomic_file.h"
#include "sector_journal.h"

namespace drtv::baker {
namespace fs = std::filesystem;
namespace {

// A whole decimal integer >= 0, nothing around it.
std::optional<long long> wholeNumber(std::string_view text) {
  long long v = 0;
  if (text.empty()) return std::nullopt;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || v < 0) return std::nullopt;
  return v;
}

// A variable of the environment as a whole number; `needed` makes an unset one an error.
Result<std::optional<long long>> envNumber(const EnvLookup& env, const char* name, bool needed, std::string_view shard) {
  const char* value = env(name);
  if (!value) {
    if (needed) return fail("--shard " + std::string(shard) + ": " + name + " is not set (not inside such a job?)");
    return std::optional<long long>();
  }
  const auto v = wholeNumber(value);
  if (!v) return fail("--shard " + std::string(shard) + ": " + name + "='" + value + "' is not a whole number");
  return std::optional<long long>(*v);
}

Result<ShardSpec> checked(long long k, long long n, const std::string& what) {
  if (n < 1 || n > (1 << 20)) return fail("--shard " + what + ": the shard count " + std::to_string(n) + " must be 1 to 1048576");
  if (k < 0 || k >= n) return fail("--shard " + what + ": shard " + std::to_string(k) + " is not in 0.." + std::to_string(n - 1));
  return ShardSpec{int(k), int(n)};
}

Result<ShardSpec> fromSlurm(const EnvLookup& env, std::optional<long long> given_count, std::string_view text) {
  auto id = envNumber(env, "SLURM_ARRAY_TASK_ID", true, text);
  if (!id) return std::unexpected(id.error());
  auto count = envNumber(env, "SLURM_ARRAY_TASK_COUNT", true, text);
  if (!count) return std::unexpected(count.error());
  auto min = envNumber(env, "SLURM_ARRAY_TASK_MIN", false, text);
  if (!min) return std::unexpected(min.error());
  auto step = envNumber(env, "SLURM_ARRAY_TASK_STEP", false, text);
  if (!step) return std::unexpected(step.error());
  const long long first = min->value_or(0), stride = step->value_or(1);
  const std::string what(text);
  if (stride < 1) return fail("--shard " + what + ": SLURM_ARRAY_TASK_STEP=" + std::to_string(stride) + " must be at least 1");
  const long long offset = **id - first;
  // An array such as --array=0,3,7 has no dense index: the shard could not tell its sectors.
  if (offset < 0 || offset % stride != 0)
    return fail("--shard " + what + ": SLURM_ARRAY_TASK_ID=" + std::to_string(**id) + " is not SLURM_ARRAY_TASK_MIN=" +
                std::to_string(first) + " plus a multiple of SLURM_ARRAY_TASK_STEP=" + std::to_string(stride) +
                " (submit the array as --array=0-<N-1>)");
  if (given_count && *given_count != **count)
    return fail("--shard " + what + ": the command line says " + std::to_string(*given_count) +
                " shards but SLURM_ARRAY_TASK_COUNT=" + std::to_string(**count));
  const long long k = offset / stride;
  if (k >= **count)
    return fail("--shard " + what + ": SLURM_ARRAY_TASK_ID=" + std::to_string(**id) + " is shard " + std::to_string(k) +
                ", past SLURM_ARRAY_TASK_COUNT=" + std::to_string(**count) + " (submit the array as --array=0-<N-1>)");
  return checked(k, **count, what);
}

Result<ShardSpec> fromKubernetes(const EnvLookup& env, std::optional<long long> given_count, std::string_view text) {
  auto index = envNumber(env, "JOB_COMPLETION_INDEX", true, text);
  if (!index) return std::unexpected(index.error());
  long long n = 0;
  if (given_count) {
    n = *given_count;
  } else {
    auto count = envNumber(env, "DRTV_SHARD_COUNT", false, text);
    if (!count) return std::unexpected(count.error());
    if (!*count)
      return fail("--shard " + std::string(text) + ": the shard count is missing: pass --shard k8s/N or set DRTV_SHARD_COUNT "
                  "(the Job's completions)");
    n = **count;
  }
  if (**index >= n)
    return fail("--shard " + std::string(text) + ": JOB_COMPLETION_INDEX=" + std::to_string(**index) + " is past the " +
                std::to_string(n) + " shards");
  return checked(**index, n, std::string(text));
}

std::optional<ShardStatus::State> parseState(const std::string& s) {
  if (s == "running") return ShardStatus::State::kRunning;
  if (s == "done") return ShardStatus::State::kDone;
  if (s == "failed") return ShardStatus::State::kFailed;
  return std::nullopt;
}

Result<ShardStatus> readStatus(const fs::path& file) {
  std::ifstream f(file, std::ios::binary);
  if (!f) return fail(file.string() + ": cannot open");
  std::stringstream text;
  text << f.rdbuf();
  const nlohmann::json j = nlohmann::json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  const auto bad = [&](const std::string& why) { return fail(file.string() + ": not a shard status: " + why); };
  if (j.is_discarded() || !j.is_object()) return bad("not a JSON object");
  ShardStatus s;
  const auto number = [&](const char* key, long long lo, long long hi) -> std::optional<long long> {
    if (!j.contains(key) || !j[key].is_number_integer()) return std::nullopt;
    const long long v = j[key].get<long long>();
    if (v < lo || v > hi) return std::nullopt;
    return v;
  };
  const auto k = number("shard", 0, 1 << 20), n = number("of", 1, 1 << 20);
  if (!k || !n || *k >= *n) return bad("\"shard\" and \"of\" must be whole numbers with 0 <= shard < of");
  s.index = int(*k);
  s.count = int(*n);
  const auto state = j.contains("state") && j["state"].is_string() ? parseState(j["state"].get<std::string>()) : std::nullopt;
  if (!state) return bad("\"state\" must be running, done or failed");
  s.state = *state;
  const auto text_of = [&](const char* key) { return j.contains(key) && j[key].is_string() ? j[key].get<std::string>() : std::string(); };
  s.fingerprint = text_of("fingerprint");
  s.world = text_of("world");
  s.host = text_of("host");
  s.error = text_of("error");
  if (const std::string split = text_of("split"); !split.empty()) s.split = split;  // older statuses: estimated
  if (j.contains("settings") && j["settings"].is_object())
    for (const auto& [key, value] : j["settings"].items())
      if (value.is_string()) s.settings.emplace_back(key, value.get<std::string>());
  s.sectors = size_t(number("sectors", 0, 1ll << 40).value_or(0));
  s.baked = size_t(number("baked", 0, 1ll << 40).value_or(0));
  s.cost = uint64_t(number("cost", 0, 1ll << 62).value_or(0));
  if (j.contains("wall_s") && j["wall_s"].is_number()) s.wall_s = j["wall_s"].get<double>();
  s.peak_rss_bytes = uint64_t(number("peak_rss_bytes", 0, 1ll << 62).value_or(0));  // older statuses: 0
  return s;
}

}  // namespace

std::optional<ShardBalance> shardBalance(std::span<const ShardTime> done) {
  ShardBalance b;
  double sum = 0;
  for (const ShardTime& t : done) {
    ++b.done;
    sum += t.wall_s;
    if (b.done == 1 || t.wall_s > b.slowest_s) b.slowest = t.index, b.slowest_s = t.wall_s;
    b.most_peak = std::max(b.most_peak, t.peak_rss_bytes);
  }
  if (b.done < 2 || !(sum > 0)) return std::nullopt;
  b.mean_s = sum / b.done;
  return b;
}

std::optional<ShardBalance> shardBalance(std::span<const ShardStatus> statuses) {
  std::vector<ShardTime> done;
  for (const ShardStatus& s : statuses)
    if (s.state == ShardStatus::State::kDone) done.push_back({s.index, s.wall_s, s.peak_rss_bytes});
  return shardBalance(std::span<const ShardTime>(done));
}

Result<ShardSpec> parseShard(std::string_view text, const EnvLookup& env) {
  std::string_view scheduler = text;
  std::optional<long long> count;
  const size_t slash = text.find('/');
  if (slash != std::string_view::npos) {
    scheduler = text.substr(0, slash);
    const auto n = wholeNumber(text.substr(slash + 1));
    if (!n) return fail("--shard '" + std::string(text) + "': expected k/N, slurm, k8s[/N] or auto[/N] with whole numbers");
    count = *n;
  }
  if (scheduler == "slurm") return fromSlurm(env, count, text);
  if (scheduler == "k8s") return fromKubernetes(env, count, text);
  if (scheduler == "auto") {
    if (env("SLURM_ARRAY_TASK_ID")) return fromSlurm(env, count, text);
    if (env("JOB_COMPLETION_INDEX")) return fromKubernetes(env, count, text);
    return fail("--shard " + std::string(text) +
                ": neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set");
  }
  const auto k = wholeNumber(scheduler);
  if (!k || !count) return fail("--shard '" + std::string(text) + "': expected k/N, slurm, k8s[/N] or auto[/N] with whole numbers");
  return checked(*k, *count, std::string(text));
}

const char* stateName(ShardStatus::State state) {
  switch (state) {
    case ShardStatus::State::kRunning: return "running";
    case ShardStatus::State::kDone: return "done";
    case ShardStatus::State::kFailed: return "failed";
  }
  return "?";
}

fs::path shardStatusFile(const fs::path& dir, int index, int count) {
  return dir / ("shard-" + std::to_string(index) + "-of-" + std::to_string(count) + ".json");
}

Result<void> writeShardStatus(const fs::path& dir, const ShardStatus& s) {
  nlohmann::ordered_json j;
  j["shard"] = s.index;
  j["of"] = s.count;
  j["state"] = stateName(s.state);
  j["fingerprint"] = s.fingerprint;
  j["world"] = s.world;
  j["host"] = s.host.empty() ? detail::hostName() : s.host;
  j["sectors"] = s.sectors;
  j["baked"] = s.baked;
  j["cost"] = s.cost;
  j["split"] = s.split;
  j["wall_s"] = s.wall_s;
  j["peak_rss_bytes"] = s.peak_rss_bytes;
  if (!s.error.empty()) j["error"] = s.error;
  nlohmann::ordered_json settings = nlohmann::ordered_json::object();
  for (const auto& [k, v] : s.settings) settings[k] = v;
  j["settings"] = settings;
  const std::string text = j.dump(2) + "\n";
  // Two runs of one shard (a requeue overlapping a straggler) must not share a temporary file.
  return detail::writeFileAtomically(shardStatusFile(dir, s.index, s.count), text);
}

Result<std::vector<ShardStatus>> readShardStatuses(const fs::path& dir) {
  std::vector<ShardStatus> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  std::vector<fs::path> files;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with("shard-") && name.ends_with(".json")) files.push_back(it->path());
  }
  if (ec) return fail(dir.string() + ": cannot list: " + ec.message());
  for (const fs::path& file : files) {
    auto s = readStatus(file);
    if (!s) return std::unexpected(s.error());
    if (file.filename() != shardStatusFile(dir, s->index, s->count).filename())
      return fail(file.string() + ": says it is shard " + std::to_string(s->index) + " of " + std::to_string(s->count));
    out.push_back(std::move(*s));
  }
  std::sort(out.begin(), out.end(), [](const ShardStatus& a, const ShardStatus& b) {
    return std::pair(a.count, a.index) < std::pair(b.count, b.index);
  });
  return out;
}

Result<void> recordShardFailure(const fs::path& archive, ShardSpec spec, const std::string& message) {
  const fs::path dir = sectorDirectory(archive);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());
  ShardStatus s;
  if (auto old = readStatus(shardStatusFile(dir, spec.index, spec.count)); old) s = std::move(*old);
  s.index = spec.index;
  s.count = spec.count;
  s.state = ShardStatus::State::kFailed;
  s.host.clear();
  s.error = message;
  return writeShardStatus(dir, s);
}

Result<FarmStatus> farmStatus(const fs::path& archive) {
  FarmStatus out;
  const fs::path dir = sectorDirectory(archive);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    out.packed = fs::is_regular_file(archive, ec);
    if (!out.packed) return fail(dir.string() + ": no sector folder and no archive " + archive.string() + ": no shard has run yet");
    return out;
  }
  auto statuses = readShardStatuses(dir);
  if (!statuses) return std::unexpected(statuses.error());
  // The split is the one most status files name (normally the only one); others are listed.
  std::map<int, int> splits;
  for (const ShardStatus& s : *statuses) ++splits[s.count];
  for (const auto& [n, c] : splits)
    if (out.count == 0 || c > splits[out.count]) out.count = n;
  std::string fingerprint, cost_split;
  for (const ShardStatus& s : *statuses)
    if (s.count == out.count && !s.fingerprint.empty()) fingerprint = s.fingerprint, cost_split = s.split;
  for (int k = 0; k < out.count; ++k) {
    FarmShard shard;
    shard.index = k;
    shard.state = "missing";
    const fs::path journal = dir / ("sectors-" + std::to_string(k) + "-of-" + std::to_string(out.count) + ".log");
    if (fs::exists(journal, ec)) {
      auto records = detail::scanJournals(dir, journal.filename().string());
      if (!records) return std::unexpected(records.error());
      shard.journaled = records->size();
      shard.state = "running";  // a journal without a status: a shard of a drtv before status files
    }
    out.shards.push_back(shard);
  }
  for (const ShardStatus& s : *statuses) {
    if (s.count != out.count) {
      out.problems.push_back(shardStatusFile(dir, s.index, s.count).string() + ": shard " + std::to_string(s.index) + "/" +
                             std::to_string(s.count) + " of another split (" + stateName(s.state) + ")");
      continue;
    }
    if (!fingerprint.empty() && !s.fingerprint.empty() && s.fingerprint != fingerprint)
      out.problems.push_back(shardStatusFile(dir, s.index, s.count).string() + ": shard " + std::to_string(s.index) + "/" +
                             std::to_string(s.count) + " of another bake (fingerprint " + s.fingerprint + ", not " + fingerprint + ")");
    else if (!fingerprint.empty() && !s.fingerprint.empty() && s.split != cost_split)
      // Shards that split by other costs (one given --costs, one not) may leave sectors to nobody.
      out.problems.push_back(shardStatusFile(dir, s.index, s.count).string() + ": shard " + std::to_string(s.index) + "/" +
                             std::to_string(s.count) + " split the sectors by '" + s.split + "', the others by '" + cost_split +
                             "' (give every shard the same --costs)");
    FarmShard& shard = out.shards[size_t(s.index)];
    shard.state = stateName(s.state);
    if (s.state == ShardStatus::State::kRunning) {
      // A running shard holds its journal's lock (bake.cpp opens the journal before it writes
      // "running"); a status that says running over a journal nobody holds is a shard that was
      // killed, preempted or lost with its machine. Without locks it cannot be told.
      const fs::path journal = dir / ("sectors-" + std::to_string(s.index) + "-of-" + std::to_string(s.count) + ".log");
      auto held = detail::journalHeld(journal);
      if (!held) return std::unexpected(held.error());
      if (*held == false) shard.state = "stopped";
    }
    shard.error = s.error;
    shard.host = s.host;
    shard.sectors = s.sectors;
    shard.cost = s.cost;
    shard.wall_s = s.wall_s;
    shard.peak_rss_bytes = s.peak_rss_bytes;
  }
  return out;
}

std::vector<int> shardOwners(std::span<const uint64_t> costs, int count) {
  DRTV_CHECK(count >= 1);
  std::vector<size_t> order(costs.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return costs[a] > costs[b]; });
  // The least-loaded shard, lowest index first: a heap of (load, index).
  using Load = std::pair<uint64_t, int>;
  std::priority_queue<Load, std::vector<Load>, std::greater<Load>> loads;
  for (int k = 0; k < count; ++k) loads.push({0, k});
  std::vector<int> owner(costs.size(), 0);
  for (const size_t i : order) {
    auto [load, k] = loads.top();
    loads.pop();
    owner[i] = k;
    const uint64_t add = costs[i];
    loads.push({load > UINT64_MAX - add ? UINT64_MAX : load + add, k});
  }
  return owner;
}

}  // namespace drtv::baker
