// drtv bake <world.json> -o <archive> [--threads N] [--quality draft|default|high]
//           [--sectors x0:x1,y0:y1] [--shard k/N|slurm|k8s[/N]|auto[/N]] [--merge] [--fresh] [--keep-sectors] [--seed S]
//           [--representation fc3|sh-l1] [--costs bake-report.json]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "drtv/baker/bake.h"
#include "drtv/baker/shard.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/load.h"

namespace drtv::app {
namespace {

struct BakeCliOptions {
  std::string world;
  std::string output;
  int threads = 0;
  std::string quality = "default";
  std::string sectors;
  std::string shard;
  bool merge = false;
  bool fresh = false;
  bool keep_sectors = false;
  uint64_t seed = 1;
  std::string representation;  // "" = the world's (else sh-l1)
  std::optional<double> clearance_m;
  std::string inside_cells;
  std::string grid_sides;
  std::optional<int> visibility_rays;
  std::string rooms;
  std::string cache_cells;
  std::string fine;
  std::string light_sources;
  std::optional<double> enclosed_spacing_m;
  std::optional<double> covered_stack_m;
  std::optional<int> sweeps;
  std::string costs;  // an earlier bake's report: the shards split by its sector times
};

void drawProgress(size_t done, size_t total) {
  constexpr int kWidth = 40;
  const int filled = total ? int(double(done) / double(total) * kWidth) : kWidth;
  std::fprintf(stderr, "\rbake [%.*s%.*s] %zu/%zu sectors", filled, "########################################", kWidth - filled,
               "                                        ", done, total);
  if (done == total) std::fputc('\n', stderr);
  std::fflush(stderr);
}

Result<void> runBake(const BakeCliOptions& o) {
  baker::BakeOptions options;
  const auto quality = baker::parseQuality(o.quality);
  if (!quality) return fail("--quality '" + o.quality + "': expected draft, default or high");
  options.quality = *quality;
  options.threads = o.threads;
  options.seed = o.seed;
  if (!o.representation.empty()) {
    const auto r = parseRepresentation(o.representation);
    if (!r) return fail("--representation '" + o.representation + "': expected one of " + representationNames());
    options.representation = *r;
  }
  options.clearance_m = o.clearance_m;
  if (!o.inside_cells.empty()) options.inside_from_neighbours = o.inside_cells == "neighbour";
  if (!o.grid_sides.empty()) options.grid_same_side = o.grid_sides == "same";
  options.visibility_rays = o.visibility_rays;
  if (!o.rooms.empty()) options.find_rooms = o.rooms == "auto";
  if (!o.cache_cells.empty()) options.cell_sides = o.cache_cells == "sides";
  if (!o.fine.empty()) options.covered_visibility = o.fine == "on";
  if (!o.light_sources.empty()) options.light_sources = o.light_sources == "at-lights";
  options.enclosed_spacing_m = o.enclosed_spacing_m;
  options.covered_stack_m = o.covered_stack_m;
  options.sweeps = o.sweeps;
  options.fresh = o.fresh;
  options.keep_sector_files = o.keep_sectors;
  options.merge_only = o.merge;
  if (!o.sectors.empty()) {
    auto r = parseSectors(o.sectors);
    if (!r) return std::unexpected(r.error());
    options.sectors = *r;
  }
  if (!o.shard.empty()) {
    auto shard = baker::parseShard(o.shard, [](const char* name) { return std::getenv(name); });
    if (!shard) return std::unexpected(shard.error());  // the option's check took it already
    options.shard_index = shard->index;
    options.shard_count = shard->count;
    if (o.merge) return fail("--merge packs what all shards baked; it takes no --shard");
  }
  if (showProgress()) options.progress = drawProgress;

  const std::filesystem::path archive(o.output);
  // bake() records its own failures in the shard's status; these come before it.
  const auto shardFailed = [&](const Error& e) -> std::unexpected<Error> {
    if (options.shard_count > 1 && !o.merge) (void)baker::recordShardFailure(archive, {options.shard_index, options.shard_count}, e.message);
    return std::unexpected(e);
  };
  if (auto made = createParentFolder(o.output); !made) return shardFailed(made.error());
  if (!o.costs.empty()) {
    auto costs = baker::readMeasuredCosts(o.costs);
    if (!costs) return shardFailed(costs.error());
    options.costs = std::move(*costs);
  }
  auto world = worlds::loadWorld(o.world);
  if (!world) return shardFailed(world.error());
  auto report = baker::bake(*world, o.world, archive, options);
  if (!report) return std::unexpected(report.error());

  // An empty bake is a valid archive but never what was wanted: say so, loudly, in the report
  // and on stderr (placement needs static geometry under its 4 m columns, or a small object).
  size_t baked_probes = 0;
  for (const auto& s : report->sectors) baked_probes += s.probes;
  if (report->packed && baked_probes == 0) {
    const std::string why = o.world + ": the bake placed no probe in any of its " + std::to_string(report->sectors.size()) +
                            " sectors: the archive gives no ambient anywhere (placement puts probes above upward-facing "
                            "terrain and static surfaces and on vegetation boxes; dynamic objects place none)";
    report->notes.push_back("warning: " + why);
    std::fprintf(stderr, "drtv: warning: %s\n", why.c_str());
  }

  std::filesystem::path dir = archive.parent_path();
  std::string stem = "bake-report";
  if (!report->shard.empty()) stem += ".shard-" + std::to_string(options.shard_index) + "-of-" + std::to_string(options.shard_count);
  if (auto w = baker::writeReports(*report, dir / (stem + ".json"), dir / (stem + ".md")); !w) return w;

  size_t probes = 0, sectors = 0;
  uint64_t rays = 0;
  for (const auto& s : report->sectors) {
    probes += s.probes;
    sectors += s.probes > 0;
    rays += s.rays();
  }
  if (report->packed)
    std::printf("baked %s: %zu sectors, %zu probes, %.1f M rays in %.2f s, peak %s resident -> %s\n", o.world.c_str(), sectors,
                probes, double(rays) / 1e6, report->wall_s, formatBytes(report->peak_rss_bytes).c_str(), o.output.c_str());
  else
    std::printf("baked shard %s of %s: %zu sectors so far, %zu probes, peak %s resident (sector journals in %s; run --merge when all "
                "shards are done)\n",
                report->shard.c_str(), o.world.c_str(), sectors, probes, formatBytes(report->peak_rss_bytes).c_str(),
                baker::sectorDirectory(archive).string().c_str());
  return {};
}

}  // namespace

Command registerBake(CLI::App& app) {
  auto o = std::make_shared<BakeCliOptions>();
  CLI::App* sub = app.add_subcommand("bake", "Bake a world into a sectorised archive (probes, index grids, PRT, LPRT)");
  sub->add_option("world", o->world, "World file (.json, .gltf, .glb)")->required();
  sub->add_option("-o,--output", o->output, "Archive to write; bake-report.json/.md go next to it")->required();
  sub->add_option("--threads", o->threads, "Worker threads (0 = all cores)");
  sub->add_option("--quality", o->quality, "draft | default | high")->check(CLI::IsMember({"draft", "default", "high"}));
  sub->add_option("--sectors", o->sectors, "Only sectors x0:x1,y0:y1 (inclusive sector keys)");
  sub->add_option("--shard", o->shard,
                  "Bake shard k of N (the sectors balanced by estimated cost, or --costs, the same split in every shard); pack later with --merge. k/N, or from the scheduler: "
                  "slurm (SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT), k8s[/N] "
                  "(JOB_COMPLETION_INDEX of N, else of DRTV_SHARD_COUNT), auto[/N] (whichever is set)")
      ->check(CLI::Validator(
          [](std::string& v) -> std::string {
            auto shard = baker::parseShard(v, [](const char* name) { return std::getenv(name); });
            return shard ? std::string() : shard.error().message;
          },
          "SHARD"));
  sub->add_option("--costs", o->costs,
                  "An earlier bake's bake-report.json of this world (a draft bake, the last bake, a farm bake's merge): the shards "
                  "split the sectors by its measured times instead of their triangles; give every shard and the merge the same")
      ->type_name("REPORT");
  sub->add_flag("--merge", o->merge, "Pack the sectors all shards wrote (their journals) into the archive");
  sub->add_flag("--fresh", o->fresh, "Discard sector journals left by a different bake");
  sub->add_flag("--keep-sectors", o->keep_sectors, "Keep <archive>.sectors/ after packing");
  sub->add_option("--seed", o->seed, "Seed of every random number (default 1)");
  sub->add_option("--representation", o->representation,
                  "Directional representation: sh-l1 (band-1 SH irradiance, default) | fc3 (the talk's 4 bases); "
                  "overrides the world's \"representation\"");
  sub->add_option("--clearance", o->clearance_m,
                  "Least distance from a probe to static geometry, metres, and half the least gap a probe may stand in "
                  "(default 0.25; 0 = the talk's placement)")
      ->check(CLI::Range(0.0, 64.0));
  sub->add_option("--inside-cells", o->inside_cells,
                  "What an index cell whose centre is inside geometry names: neighbour (a resolved neighbour cell's probe, "
                  "default) | nearest (the talk's nearest probe, which may be behind a wall)")
      ->check(CLI::IsMember({"neighbour", "nearest"}));
  sub->add_option("--grid-sides", o->grid_sides,
                  "Which probes an index cell names: same (the nearest visible probe on the cell's side of the sky line: "
                  "under a roof a covered probe, under open sky an uncovered one, so that the street beside a facade "
                  "does not name a room's probe through its window; default) | any (the nearest visible probe, the bytes "
                  "of the builds before 2026-12-06's second session)")
      ->check(CLI::IsMember({"same", "any"}));
  sub->add_option("--visibility-rays", o->visibility_rays,
                  "Rays a covered probe's visibility map is filtered from (the fine level's test of which probes see a "
                  "point): default 1024; 4096 = the bytes of the builds before 2026-12-06's second session")
      ->check(CLI::Range(64, 16384));
  sub->add_option("--rooms", o->rooms,
                  "Closed rooms found in the geometry get an interior volume and a designated probe, as an artist's "
                  "interiors do: auto (default) | off (the artist's interiors only)")
      ->check(CLI::IsMember({"auto", "off"}));
  sub->add_option("--cache-cells", o->cache_cells,
                  "Surface cache cells (sh-l1): sides (a cell splits where a wall separates the surfaces in it, so a "
                  "room's floor does not share the ground's light outside its wall; default) | shared (one per cube "
                  "and facing, the bytes of the builds before 2026-12-03)")
      ->check(CLI::IsMember({"sides", "shared"}));
  sub->add_option("--fine", o->fine,
                  "The fine level near surfaces: probes under roofs get visibility maps, so that the runtime blends the "
                  "ones that see a point and never one behind a wall: on (default) | off (the bytes of the builds "
                  "before 2026-12-05)")
      ->check(CLI::IsMember({"on", "off"}));
  sub->add_option("--light-sources", o->light_sources,
                  "LPRT sources of lights that stand still under a roof: at-lights (a source where each such light "
                  "stands, which the runtime gives that light whole; default) | probes (the probes around each light "
                  "share it, as they do lights in the open and moving lights; the bytes of the builds before "
                  "2026-12-06)")
      ->check(CLI::IsMember({"at-lights", "probes"}));
  sub->add_option("--sweeps", o->sweeps,
                  "Jacobi sweeps of the sun's and sky's bounces over the surface cache (default 4): more carry further "
                  "bounces around closed rooms with no more rays; 0 = bounces - 1 (the bytes of the builds before 2026-12-07)")
      ->check(CLI::Range(0, 256));
  sub->add_option("--enclosed-spacing", o->enclosed_spacing_m,
                  "Probe spacing in enclosed spaces under roofs (rooms, storeys), metres: columns this far apart and "
                  "probes no nearer each other, for the fine level to blend (default 2); 0 = the spacing under any roof "
                  "(the bytes of the builds before 2026-12-06)")
      ->check(CLI::Range(0.0, 64.0));
  sub->add_option("--covered-stack", o->covered_stack_m,
                  "Under roofs, a probe every this many metres up a space taller than a storey (a hall, an atrium, a "
                  "stairwell), so that its ceiling is in the fine level's reach (default 3); 0 = one probe per floor "
                  "(the bytes of the builds before 2026-12-07's sixth session)")
      ->check(CLI::Range(0.0, 64.0));
  return {sub, [o]() { return runBake(*o); }, &o->world};
}

}  // namespace drtv::app
