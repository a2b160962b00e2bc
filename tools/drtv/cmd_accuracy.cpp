// drtv accuracy <world.json> -o <dir> [--stratify] [--points N] [--samples N] [--time HH:MM,HH:MM]
//               [--sectors x0:x1,y0:y1] [--seed S] [--threads N] [--techniques a,b] [--knobs lpv,sweep]
// Bakes the world in memory and sweeps each knob around the default against the path-traced
// reference (accuracy.h); writes accuracy.csv, .json, .md and .png into the directory.
#include <cstdio>
#include <memory>
#include <sstream>

#include "commands.h"
#include "drtv/eval/accuracy.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/load.h"

namespace drtv::app {
namespace {

struct AccuracyCliOptions {
  std::string world, output = "accuracy", times = "09:00,16:00", sectors;
  int points = 240, samples = 512, probe_samples = 256, threads = 0;
  uint64_t seed = 1;
  std::vector<std::string> techniques;
  std::vector<std::string> knobs;
  bool stratify = false;
};

Result<std::vector<double>> parseHours(const std::string& text) {
  std::vector<double> out;
  std::istringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    auto hour = parseTimeOfDay(item);
    if (!hour) return std::unexpected(hour.error());
    out.push_back(*hour);
  }
  if (out.empty()) return fail("--time '" + text + "': expected HH:MM[,HH:MM...]");
  return out;
}

}  // namespace

Command registerAccuracy(CLI::App& app) {
  auto o = std::make_shared<AccuracyCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "accuracy", "Bake in memory and measure each knob's error against the path-traced reference, with its time and memory");
  sub->add_option("world", o->world, "World file (.json, .gltf, .glb)")->required();
  sub->add_option("-o,--output", o->output, "Directory for accuracy.csv/.json/.md/.png")->capture_default_str();
  sub->add_option("--points", o->points, "Surface sample points")->check(CLI::Range(1, 1000000))->capture_default_str();
  sub->add_option("--samples", o->samples, "Reference paths per point and hour")->check(CLI::Range(2, 1 << 20))->capture_default_str();
  sub->add_option("--probe-samples", o->probe_samples, "Reference paths per probe direction (basis rows)")
      ->check(CLI::Range(2, 1 << 20))
      ->capture_default_str();
  sub->add_option("--time", o->times, "Times of day HH:MM, comma-separated")->capture_default_str();
  sub->add_option("--sectors", o->sectors, "Sector block to bake x0:x1,y0:y1 (default: 3x3 around the centre)");
  sub->add_option("--seed", o->seed, "Seed of every random number")->capture_default_str();
  sub->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  const std::string names = eval::registeredTechniqueNames();
  sub->add_option("--techniques", o->techniques, "The techniques of the \"technique\" rows, comma-separated (default all: " + names + ")")
      ->delimiter(',');
  sub->add_option("--knobs", o->knobs,
                  "Also these techniques' own knob rows, comma-separated (lpv: minutes each; sweep, ambient-cube: seconds each); "
                  "DRTV's are always there")
      ->delimiter(',');
  sub->add_flag("--stratify", o->stratify,
                "Give each surface category found (open ground, walls, enclosed) an equal share of the static points; the totals then "
                "weigh the categories equally");
  return {sub, [o]() -> Result<void> {
            eval::AccuracyOptions opts;
            if (auto k = eval::checkKnobs(o->knobs); !k) return k;
            opts.knobs = o->knobs;
            opts.stratify = o->stratify;
            auto hours = parseHours(o->times);
            if (!hours) return std::unexpected(hours.error());
            opts.hours = *hours;
            if (!o->sectors.empty()) {
              auto r = parseSectors(o->sectors);
              if (!r) return std::unexpected(r.error());
              opts.sectors = *r;
            }
            opts.points = o->points;
            opts.reference_samples = o->samples;
            opts.probe_samples = o->probe_samples;
            opts.seed = o->seed;
            opts.threads = o->threads;
            for (const std::string& name : o->techniques) {
              auto t = eval::makeTechnique(name);
              if (!t) return std::unexpected(t.error().context("--techniques"));
            }
            opts.techniques = o->techniques;
            if (showProgress()) opts.progress = [](const std::string& line) { std::fprintf(stderr, "accuracy: %s\n", line.c_str()); };
            auto world = worlds::loadWorld(o->world);
            if (!world) return std::unexpected(world.error());
            auto report = eval::measureAccuracy(*world, o->world, opts);
            if (!report) return std::unexpected(report.error());
            if (auto w = eval::writeAccuracyReport(*report, o->output); !w) return w;
            std::printf("wrote %s/accuracy.{csv,json,md,png}: %zu rows, %zu points, %.1f s\n", o->output.c_str(),
                        report->rows.size(), report->points, report->wall_s);
            return {};
          }, &o->world};
}

}  // namespace drtv::app
