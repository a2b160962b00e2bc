// drtv — bake, inspect, query and fly through deferred radiance transfer volumes.
// Thin by design (STYLE.md): parse options, call a library, map the result to an exit code.
#include <cstdio>
#include <cstdlib>
#include <malloc.h>
#include <new>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <unistd.h>
#include <vector>

#include "commands.h"
#include "drtv/formats/memory_limit.h"

namespace drtv::app {
bool showProgress() { return ::isatty(STDERR_FILENO) && std::getenv("CI") == nullptr; }

Result<double> parseTimeOfDay(const std::string& text, const std::string& flag) {
  int h = -1, m = -1;
  char colon = 0;
  std::istringstream s(text);
  if (!(s >> h >> colon >> m) || colon != ':' || !s.eof() || h < 0 || h > 23 || m < 0 || m > 59)
    return fail(flag + " '" + text + "': expected HH:MM (00:00 to 23:59)");
  return h + m / 60.0;
}
Result<int> parseInt(const std::string& s, const std::string& flag) {
  try {
    size_t used = 0;
    const int v = std::stoi(s, &used);
    if (used != s.size()) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    return fail(flag + " '" + s + "': not an integer");
  }
}

Result<raytrace::SectorRange> parseSectors(const std::string& s) {
  const std::string flag = "--sectors";
  const size_t comma = s.find(',');
  if (comma == std::string::npos) return fail(flag + " '" + s + "': expected x0:x1,y0:y1");
  auto pair = [&](const std::string& part) -> Result<std::pair<int, int>> {
    const size_t colon = part.find(':', 1);  // skip a leading minus sign
    if (colon == std::string::npos) return fail(flag + " '" + s + "': expected x0:x1,y0:y1");
    auto a = parseInt(part.substr(0, colon), flag);
    auto b = parseInt(part.substr(colon + 1), flag);
    if (!a) return std::unexpected(a.error());
    if (!b) return std::unexpected(b.error());
    if (*b < *a) return fail(flag + " '" + s + "': range " + part + " is empty");
    return std::pair{*a, *b};
  };
  auto x = pair(s.substr(0, comma));
  if (!x) return std::unexpected(x.error());
  auto y = pair(s.substr(comma + 1));
  if (!y) return std::unexpected(y.error());
  return raytrace::SectorRange{x->first, x->second, y->first, y->second};
}

Result<glm::dvec3> parseVec3(const std::string& text, const std::string& flag) {
  std::istringstream s(text);
  glm::dvec3 v;
  char c1 = 0, c2 = 0;
  if (!(s >> v.x >> c1 >> v.y >> c2 >> v.z) || c1 != ',' || c2 != ',' || !s.eof() ||
      !(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)))
    return fail(flag + " '" + text + "': expected three finite numbers x,y,z");
  return v;
}

Result<void> createParentFolder(const std::string& path) {
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) return {};
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create the output folder: " + ec.message());
  return {};
}

CLI::Validator finiteRange(double lo, double hi, bool lo_open) {
  std::ostringstream desc;
  desc << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
  return CLI::Validator(
      [lo, hi, lo_open, text = desc.str()](std::string& value) -> std::string {
        double v = 0;
        size_t used = 0;
        try {
          v = std::stod(value, &used);
        } catch (const std::exception&) {
          return "'" + value + "' is not a number";
        }
        if (used != value.size()) return "'" + value + "' is not a number";
        if (!std::isfinite(v) || (lo_open ? !(v > lo) : !(v >= lo)) || !(v <= hi))
          return "'" + value + "' must be a finite number in " + text;
        return {};
      },
      "FINITE in " + desc.str());
}

CLI::Validator nonZeroVec3() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        auto v = parseVec3(value, "");
        if (!v) return "'" + value + "': expected three finite numbers x,y,z";
        if (v->x == 0 && v->y == 0 && v->z == 0) return "'" + value + "': the zero vector has no direction";
        return {};
      },
      "x,y,z != 0");
}

}  // namespace drtv::app

int main(int argc, char** argv) {
  // The bake allocates and frees a few MB of scratch per sector on every thread. glibc serves
  // blocks over 128 KB with mmap and returns them at free, so each sector paid for page faults on
  // fresh zeroed pages (~5% of a bake's CPU time). Keep such blocks in the heap instead; the
  // process's peak is unchanged, it only stops returning memory to the system between sectors.
  // (glibc; 32 MB is its largest mmap threshold on 64-bit. A refusal only costs that speed.)
  (void)mallopt(M_MMAP_THRESHOLD, 32 << 20);
  (void)mallopt(M_TRIM_THRESHOLD, 256 << 20);
  CLI::App app{"drtv: bakes, streams and relights probe-based global illumination for large worlds\n"
               "(after \"Deferred Radiance Transfer Volumes\", Far Cry 3, GDC 2012)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "drtv 0.1.0");
  // Memory as an input limit (drtv/formats/memory_limit.h): also after the subcommand's name,
  // which fallthrough() lets the subcommands pass up to here.
  std::string max_memory;
  app.fallthrough();
  app.add_option("--max-memory", max_memory,
                 "Memory this run may use, e.g. 8G or 512M (default: physical memory and rlimits); inputs that need "
                 "more are refused up front")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            return drtv::parseBytes(v) ? std::string() : "'" + v + "': expected a size such as 8G, 512M or 1000000";
          },
          "SIZE"));
  std::vector<drtv::app::Command> commands;
  commands.push_back(drtv::app::registerInfo(app));
  commands.push_back(drtv::app::registerBake(app));
  commands.push_back(drtv::app::registerBenchBake(app));
  commands.push_back(drtv::app::registerMap(app));
  commands.push_back(drtv::app::registerQuery(app));
  commands.push_back(drtv::app::registerFly(app));
  commands.push_back(drtv::app::registerRender(app));
  commands.push_back(drtv::app::registerAccuracy(app));
#ifdef DRTV_HAVE_VDB_EXPORT
  commands.push_back(drtv::app::registerExportVdb(app));
#endif
  commands.push_back(drtv::app::registerFarm(app));
  // One line per subcommand below.

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  } catch (const CLI::CallForAllHelp& e) {
    std::fputs(app.help("", CLI::AppFormatMode::All).c_str(), stdout);
    return 0;
  } catch (const CLI::CallForVersion& e) {
    std::puts("drtv 0.1.0");
    return 0;
  } catch (const CLI::ParseError& e) {
    // A subcommand's --help arrives here too when it is a CallForHelp thrown from the sub.
    if (e.get_exit_code() == 0) {
      std::fputs(app.help().c_str(), stdout);
      return 0;
    }
    std::fprintf(stderr, "drtv: usage error: %s\nRun 'drtv --help' for the subcommands.\n", e.what());
    return 2;
  }
  if (!max_memory.empty()) drtv::setMemoryLimit(*drtv::parseBytes(max_memory));
  for (const auto& c : commands) {
    if (!c.sub->parsed()) continue;
    try {
      if (auto r = c.run(); !r) {
        std::fprintf(stderr, "drtv: error: %s\n", r.error().message.c_str());
        return 1;
      }
    } catch (const std::bad_alloc&) {
      // A last resort: every allocation in proportion to an input is estimated and refused up
      // front (memory_limit.h). One that escapes still ends as an error naming the input.
      const std::string input = c.input ? *c.input : std::string("drtv ") + c.sub->get_name();
      const drtv::MemoryLimit left = drtv::memoryLimit();
      std::fprintf(stderr, "drtv: error: %s: out of memory (std::bad_alloc) in 'drtv %s', %s left under %s\n", input.c_str(),
                   c.sub->get_name().c_str(), drtv::formatBytes(left.bytes).c_str(), left.source.c_str());
      return 1;
    }
    return 0;
  }
  return 2;
}
