// drtv_http_flight: `drtv fly` over a real nginx with added network latency, beside the same flight
// from the file, at several speeds; one table of misses, load latency and frame time (issue 37).
//
//   drtv_http_flight ARCHIVE [--drtv PATH ...] [--latency-ms 20] [--speeds 100,300,1000]
//                    [--io-threads 16] [--frames N] [--keep DIR]
//
// nginx (Debian's, started here on a free loopback port with its files in a temporary folder and
// stopped by its PID) serves the archive's folder; bench/common/fault_proxy.h sits in front of it
// and holds every answer and every new connection `--latency-ms` (one round trip of a server that
// far away, per connection, so that reads in flight overlap as over a real network). Each `--drtv`
// binary (default: this build's) flies the archive's default path at each speed, from the file and
// then from the URL, with `--io-threads N` (the flight kept to real time), as its own process; the
// figures are read back from its fly-report.json. Give an old binary and a new one to compare them
// in one run. A benchmark, not a test: the misses depend on the machine's load.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include "fault_proxy.h"
#include "nginx_server.h"

extern char** environ;

namespace {

// Runs `argv` (argv[0] a path, or a name looked up in PATH) with its standard output and error in `log`, no shell between:
// its exit status, or -1 when it could not be started or did not exit.
int runLogged(const std::vector<std::string>& argv, const std::filesystem::path& log) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  if (waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

int usage(const char* why) {
  std::fprintf(stderr,
               "drtv_http_flight: %s\nusage: drtv_http_flight ARCHIVE [--drtv PATH ...] [--latency-ms 20] "
               "[--speeds 100,300,1000] [--io-threads 16] [--frames N] [--keep DIR]\n",
               why);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::filesystem::path archive;
  std::vector<std::string> binaries;
  double latency_ms = 20.0;
  std::vector<double> speeds;
  int io_threads = 16, frames = 0;
  std::filesystem::path keep;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
    if (a == "--drtv") binaries.push_back(next());
    else if (a == "--latency-ms") latency_ms = std::atof(next().c_str());
    else if (a == "--speeds") {
      std::stringstream in(next());
      for (std::string x; std::getline(in, x, ',');) speeds.push_back(std::atof(x.c_str()));
    } else if (a == "--io-threads") io_threads = std::atoi(next().c_str());
    else if (a == "--frames") frames = std::atoi(next().c_str());
    else if (a == "--keep") keep = next();
    else if (!a.empty() && a[0] == '-') return usage(("unknown option " + a).c_str());
    else archive = a;
  }
  if (archive.empty()) return usage("no archive given");
  if (!std::filesystem::is_regular_file(archive)) return usage((archive.string() + ": no such file").c_str());
  if (!(latency_ms >= 0.0 && latency_ms <= 10000.0)) return usage("--latency-ms must be 0..10000");
  if (io_threads < 1 || io_threads > 64) return usage("--io-threads must be 1..64");
  if (speeds.empty()) speeds = {100.0, 300.0, 1000.0};
  for (double s : speeds)
    if (!(s > 0.0 && s <= 10000.0)) return usage("--speeds: each in (0, 10000]");
  if (binaries.empty()) binaries.push_back(DRTV_TOOL);
  archive = std::filesystem::absolute(archive);

  const auto dir = std::filesystem::temp_directory_path() / ("drtv_http_flight_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "www");
  std::filesystem::create_symlink(archive, dir / "www" / archive.filename());
  int status = 0;
  {
    drtv::testing::NginxServer nginx(dir / "nginx", dir / "www", "");
    if (auto ok = nginx.start(); !ok) {
      std::fprintf(stderr, "drtv_http_flight: %s\n", ok.error().message.c_str());
      std::filesystem::remove_all(dir);
      return 1;
    }
    drtv::testing::FaultProxy proxy(nginx.port());
    proxy.setLatency(std::chrono::microseconds(int64_t(latency_ms * 1000.0)));
    const std::string url = proxy.url("/" + archive.filename().string());

    std::printf("%s: default path, %d I/O threads, flight in real time; HTTP through nginx on loopback + %.0f ms per round trip\n\n",
                archive.filename().c_str(), io_threads, latency_ms);
    std::printf("| drtv | source | m/s | frames | loads | misses (frames) | latency ms p50 / p99 / max | guard s max | frame ms p99 |\n");
    std::printf("|---|---|---:|---:|---:|---:|---|---:|---:|\n");
    int run = 0;
    for (const std::string& bin : binaries)
      for (double speed : speeds)
        for (const bool http : {false, true}) {
          const auto out = (keep.empty() ? dir : keep) / ("run" + std::to_string(run++));
          std::vector<std::string> argv = {bin, "fly", http ? url : archive.string(), "--speed", std::to_string(speed),
                                            "--io-threads", std::to_string(io_threads), "-o", out.string()};
          if (frames > 0) argv.insert(argv.end(), {"--frames", std::to_string(frames)});
          std::filesystem::create_directories(out.parent_path());
          const int rc = runLogged(argv, out.string() + ".log");
          std::ifstream f(out / "fly-report.json");
          nlohmann::json j = nlohmann::json::parse(f, nullptr, /*allow_exceptions=*/false);
          if (rc != 0 || j.is_discarded()) {
            if (rc == -1)
              std::printf("| %s | %s | %.0f | could not run it (or it did not exit) |\n", bin.c_str(), http ? "HTTP" : "file", speed);
            else
              std::printf("| %s | %s | %.0f | failed: see %s.log |\n", bin.c_str(), http ? "HTTP" : "file", speed, out.c_str());
            status = 1;
            continue;
          }
          const auto& s = j["summary"];
          auto num = [&](const char* key) { return s.contains(key) ? s[key].get<double>() : -1.0; };
          std::printf("| %s | %s | %.0f | %d | %lld | %lld (%lld) | %.1f / %.1f / %.1f | %.2f | %.3f |\n", bin.c_str(),
                      http ? "HTTP" : "file", speed, s["frames"].get<int>(), s["loads"].get<long long>(), s["misses"].get<long long>(),
                      s["frames_with_misses"].get<long long>(), num("latency_ms_p50"), num("latency_ms_p99"), num("latency_ms_max"),
                      num("guard_s_max"), num("frame_ms_p99"));
          std::fflush(stdout);
        }
    std::printf("\n(-1: that binary does not report the figure.) Round trips held by the proxy: %lld.\n", (long long)proxy.delayed());
  }
  if (keep.empty()) std::filesystem::remove_all(dir);
  return status;
}
