// bake-report.json and bake-report.md (see bake.h, writeReports).
#include <algorithm>
#include <map>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/summary.h"
#include "sector_stats.h"

namespace drtv::baker {
namespace {

std::string fixed(double v, int digits = 1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

struct MinMeanMax {
  double min = 0, mean = 0, max = 0;
  size_t n = 0;
  void add(double v) {
    min = n ? std::min(min, v) : v;
    max = n ? std::max(max, v) : v;
    mean = (mean * double(n) + v) / double(n + 1);
    ++n;
  }
  nlohmann::json json() const { return {{"min", min}, {"mean", mean}, {"max", max}, {"count", n}}; }
};

}  // namespace


Result<void> writeReports(const BakeReport& r, const std::filesystem::path& json_path,
                          const std::filesystem::path& markdown_path) {
  MinMeanMax probes, bytes, bytes_no_lprt, triangles;
  size_t total_probes = 0, relocated = 0, dropped = 0, gap = 0, rejected = 0, thinned = 0, veg = 0, interior = 0, resumed = 0;
  size_t cells_near = 0, cells_far = 0, cells_inside = 0, cells_unseen = 0, cells_searched = 0, cells_other_side = 0, surfels = 0, cached = 0;
  uint64_t rays = 0, r_place = 0, r_probe = 0, r_surfel = 0, r_lprt = 0, r_sun = 0, r_grid = 0, r_other = 0;
  double t_gather = 0, t_build = 0, t_place = 0, t_probe = 0, t_surfel = 0, t_lprt = 0, t_sun = 0, t_grid = 0, t_vis = 0, t_total = 0;
  std::map<size_t, size_t> histogram;  // probes per sector, bucketed by 10
  for (const SectorStats& s : r.sectors) {
    resumed += s.resumed;
    relocated += s.placement.relocated;
    dropped += s.placement.dropped_inside;
    gap += s.placement.dropped_gap;
    rejected += s.placement.rejected_distance;
    thinned += s.placement.thinned_cap;
    veg += s.placement.vegetation_candidates;
    interior += s.placement.interior_probes;
    cells_near += s.grid.cells_nearest;
    cells_far += s.grid.cells_farther;
    cells_inside += s.grid.cells_inside;
    cells_unseen += s.grid.cells_unseen;
    cells_searched += s.grid.cells_searched;
    cells_other_side += s.grid.cells_other_side;
    surfels += s.transfer.surfels;
    cached += s.transfer.probe_hits_cached;
    rays += s.rays();
    r_place += s.placement.rays;
    r_probe += s.transfer.probe_rays;
    r_surfel += s.transfer.surfel_rays;
    r_lprt += s.transfer.lprt_rays;
    r_sun += s.transfer.sun_rays;
    r_grid += s.grid.rays;
    r_other += s.other_rays;
    t_gather += s.gather_s;
    t_build += s.build_s;
    t_place += s.placement_s;
    t_probe += s.transfer.probe_seconds;
    t_surfel += s.transfer.surfel_seconds;
    t_lprt += s.transfer.lprt_seconds;
    t_sun += s.transfer.sun_seconds;
    t_grid += s.grid_s;
    t_vis += s.visibility_s;
    t_total += s.total_s;
    if (s.probes == 0) continue;
    total_probes += s.probes;
    probes.add(double(s.probes));
    bytes.add(double(s.bytes));
    bytes_no_lprt.add(double(s.bytes_without_lprt));
    triangles.add(double(s.triangles));
    ++histogram[s.probes / 10 * 10];
  }
  // The placement pass's rays for sectors this bake does not bake (its sectors' own count above).
  rays += r.placement_pass.outside_rays;
  r_place += r.placement_pass.outside_rays;
  rays += r.rooms.rays;  // the room search (rooms.h), before any sector
  const double cast_s = r.bake_s + r.placement_pass.seconds;
  const double rays_per_s = cast_s > 0 ? double(rays) / cast_s : 0.0;

  nlohmann::json j;
  j["world"] = r.world;
  j["archive"] = r.archive.string();
  j["packed"] = r.packed;
  j["shard"] = r.shard;
  j["threads"] = r.threads;
  j["geometry_fingerprint"] = r.geometry_fingerprint;  // what `--costs` matches (sector_costs.h)
  j["split"] = r.split;
  nlohmann::json settings = nlohmann::json::object();
  for (const auto& [k, v] : r.settings.describe()) settings[k] = v;
  j["settings"] = settings;
  j["effects"] = {{"asked", effectsToString(r.effects_asked)}, {"baked", effectsToString(r.effects_baked)}, {"skipped", r.effects_skipped}};
  j["notes"] = r.notes;
  j["world_notes"] = r.world_notes;
  nlohmann::json materials = nlohmann::json::object();
  for (const auto& [name, count] : worlds::materialCountFields(r.materials)) materials[name] = count;
  j["materials"] = materials;
  j["triangles"] = r.triangles;
  j["sectors"] = {{"baked_or_resumed", r.sectors.size()}, {"resumed", resumed}, {"empty_skipped", r.sectors_empty},
                  {"with_probes", probes.n}};
  j["probes"] = {{"total", total_probes}, {"per_sector", probes.json()}, {"relocated", relocated},
                 {"invalid_dropped", dropped}, {"gap_or_clearance_dropped", gap}, {"rejected_min_distance", rejected}, {"thinned_cap", thinned},
                 {"vegetation_candidates", veg}, {"interior_designated", interior}};
  nlohmann::json hist = nlohmann::json::object();
  for (const auto& [b, n] : histogram) hist[std::to_string(b) + "-" + std::to_string(b + 9)] = n;
  j["probes"]["histogram"] = hist;
  j["bytes_per_sector"] = {{"with_lprt", bytes.json()}, {"without_lprt", bytes_no_lprt.json()}};
  j["triangles_per_sector"] = triangles.json();
  j["index_grid"] = {{"cells_nearest_visible", cells_near}, {"cells_farther_visible", cells_far},
                     {"cells_inside_geometry", cells_inside}, {"cells_beyond_candidates", cells_searched},
                     {"cells_other_side", cells_other_side},
                     {"cells_none_visible_take_a_neighbours", cells_unseen}};
  j["surface_cache"] = {{"surfels", surfels}, {"probe_hits_reusing_a_cell", cached}};
  j["rays"] = {{"total", rays}, {"rooms", r.rooms.rays}, {"placement", r_place}, {"probe", r_probe}, {"surfel", r_surfel}, {"lprt", r_lprt},
               {"sun", r_sun}, {"grid", r_grid}, {"other", r_other}, {"per_second_wall", rays_per_s}};
  j["placement_pass"] = {{"sectors", r.placement_pass.sectors}, {"resumed", r.placement_pass.resumed},
                         {"outside", r.placement_pass.outside}, {"outside_rays", r.placement_pass.outside_rays},
                         {"seconds", r.placement_pass.seconds}};
  j["rooms"] = {{"found", r.rooms.rooms}, {"seeds", r.rooms.seeds}, {"enclosed_seeds", r.rooms.enclosed},
                {"dropped_for_an_artists_interior", r.rooms.dropped_artist}, {"dropped_as_the_same_room", r.rooms.dropped_overlap},
                {"rays", r.rooms.rays}, {"seconds", r.rooms_s}};
  j["seconds"] = {{"wall", r.wall_s}, {"geometry", r.geometry_s}, {"rooms", r.rooms_s}, {"placement_pass", r.placement_pass.seconds},
                  {"bake", r.bake_s}, {"pack", r.pack_s},
                  {"sum_over_sectors",
                   {{"gather", t_gather}, {"scene_build", t_build}, {"placement", t_place}, {"probe_rays", t_probe},
                    {"surface_cache", t_surfel}, {"lprt", t_lprt}, {"sun_transfer", t_sun}, {"visibility_maps", t_vis}, {"index_grid", t_grid}, {"total", t_total}}}};
  j["memory"] = {{"peak_resident_bytes", r.peak_rss_bytes}};
  const std::optional<ShardBalance> balance = shardBalance(std::span<const ShardStatus>(r.shards));  // a merge's
  if (!r.shards.empty()) {
    nlohmann::json list = nlohmann::json::array();
    for (const ShardStatus& s : r.shards)
      list.push_back({{"shard", s.index}, {"of", s.count}, {"state", stateName(s.state)}, {"sectors", s.sectors}, {"cost", s.cost},
                      {"wall_s", s.wall_s}, {"peak_resident_bytes", s.peak_rss_bytes}, {"host", s.host}});
    j["shards"] = list;
    if (const auto& b = balance)
      j["shard_balance"] = {{"slowest", b->slowest}, {"slowest_s", b->slowest_s}, {"mean_s", b->mean_s},
                            {"slowest_over_mean", b->slowest_s / b->mean_s}, {"most_peak_resident_bytes", b->most_peak}};
  }
  {
    nlohmann::json bs = nlohmann::json::array();
    for (const BuildingStats& b : r.buildings)
      bs.push_back({{"min_m", {b.min.x, b.min.y}}, {"max_m", {b.max.x, b.max.y}}, {"bottom_z_m", b.bottom_z}, {"top_z_m", b.top_z},
                    {"probes", b.probes}, {"storey_probes", b.storey_probes}, {"rooms", b.rooms}, {"bytes", b.bytes},
                    {"sectors", b.sectors}});
    j["buildings"] = bs;
  }
  nlohmann::json per = nlohmann::json::array();
  for (const SectorStats& s : r.sectors) per.push_back(toJson(s));
  j["per_sector"] = per;
  {
    std::ofstream f(json_path, std::ios::trunc);
    if (!f) return fail(json_path.string() + ": cannot open for writing");
    f << j.dump(2) << "\n";
    if (!f) return fail(json_path.string() + ": write failed");
  }

  std::ostringstream md;
  md << "# Bake report\n\n";
  md << "- world: `" << r.world << "`\n- archive: `" << r.archive.string() << "`" << (r.packed ? "" : " (not packed: shard)") << "\n";
  if (!r.shard.empty()) md << "- shard: " << r.shard << "\n";
  md << "- quality: " << qualityName(r.settings.quality) << ", threads: " << r.threads << "\n";
  md << "- effects baked: " << effectsToString(r.effects_baked) << "\n";
  for (const std::string& s : r.effects_skipped) md << "- skipped: " << s << "\n";
  for (const std::string& n : worlds::collapseNotes(r.notes)) md << "- geometry " << n << "\n";
  md << "- " << worlds::materialCountsLine(r.materials) << "\n";
  for (const std::string& n : worlds::collapseNotes(r.world_notes)) md << "- loader " << n << "\n";
  md << "\n## Probes\n\n| | value |\n|---|---|\n";
  md << "| sectors with probes | " << probes.n << " (" << r.sectors_empty << " empty, not stored; " << resumed << " resumed) |\n";
  md << "| probes | " << total_probes << " |\n";
  md << "| per sector min / mean / max | " << fixed(probes.min, 0) << " / " << fixed(probes.mean) << " / " << fixed(probes.max, 0) << " |\n";
  md << "| relocated out of geometry or away from a surface | " << relocated << " |\n";
  md << "| invalid (inside geometry, dropped) | " << dropped << " |\n";
  md << "| in a gap under 2 x clearance, or nearer a surface than it with no way out (dropped) | " << gap << " |\n";
  md << "| rejected by minimum distance | " << rejected << " |\n";
  md << "| thinned to the 255 cap | " << thinned << " |\n";
  md << "| interior designated | " << interior << " |\n";
  md << "\nProbes per sector:\n\n| probes | sectors |\n|---|---|\n";
  for (const auto& [b, n] : histogram) md << "| " << b << "-" << b + 9 << " | " << n << " |\n";
  md << "\n## Bytes per sector (encoded, before zstd)\n\n| | min | mean | max |\n|---|---|---|---|\n";
  if (r.effects_baked & kEffectLocalLights)
    md << "| as stored, with LPRT | " << fixed(bytes.min, 0) << " | " << fixed(bytes.mean, 0) << " | " << fixed(bytes.max, 0) << " |\n";
  else
    md << "| as stored (no LPRT: the world has no local lights) | " << fixed(bytes.min, 0) << " | " << fixed(bytes.mean, 0) << " | "
       << fixed(bytes.max, 0) << " |\n";
  md << "| without LPRT | " << fixed(bytes_no_lprt.min, 0) << " | " << fixed(bytes_no_lprt.mean, 0) << " | " << fixed(bytes_no_lprt.max, 0) << " |\n";
  md << "\n## Index grid\n\n" << cells_near << " cells took the nearest probe, " << cells_far
     << " a farther one because nearer ones were hidden, " << cells_inside << " lie inside geometry (a neighbour cell's choice), "
     << cells_searched << " saw none of the nearest candidates but a farther probe, " << cells_unseen
     << " saw no probe at all (a neighbour cell's choice); " << cells_other_side
     << " saw no probe on their side of the sky line (covered or open) and took any.\n";
  md << "\n## Rays\n\n| stage | rays |\n|---|---|\n";
  md << "| room search | " << r.rooms.rays << " |\n";
  md << "| placement | " << r_place << " |\n| probe basis rays | " << r_probe << " |\n| surface cache | " << r_surfel
     << " (" << surfels << " cells) |\n| LPRT shadow rays | " << r_lprt << " |\n| index grid visibility | " << r_grid
     << " |\n| ground map and visibility maps | " << r_other << " |\n| **total** | **" << rays << "** |\n";
  md << "\n" << fixed(rays_per_s / 1e6, 2) << " M rays/s over the bake's wall time (placement pass and sectors).\n";
  if (r.placement_pass.sectors > 0)
    md << "\nPlacement pass (LPRT sources are the neighbours' probes): " << r.placement_pass.sectors << " sectors placed ("
       << r.placement_pass.resumed << " read back from placement journals, " << r.placement_pass.outside
       << " only as neighbours), " << r.placement_pass.outside_rays << " rays for those, " << fixed(r.placement_pass.seconds, 2)
       << " s.\n";
  if (r.settings.rooms.enabled)
    md << "\nRooms (closed rooms given an interior volume and a designated probe, rooms.h): " << r.rooms.rooms << " found from "
       << r.rooms.seeds << " covered-air seeds (" << r.rooms.enclosed << " enclosed; " << r.rooms.dropped_artist
       << " rooms inside an artist's interior and " << r.rooms.dropped_overlap << " seen twice dropped), " << r.rooms.rays
       << " rays, " << fixed(r.rooms_s, 2) << " s.\n";
  if (!r.buildings.empty()) {
    // The largest first; every one is in the JSON.
    size_t probes = 0, rooms = 0, bytes = 0, storeys = 0;
    for (const BuildingStats& b : r.buildings) probes += b.probes, rooms += b.rooms, bytes += b.bytes, storeys += b.storey_probes.size();
    const BuildingOptions bo;
    md << "\n## Buildings\n\nCovered probes (the fine level's, each with a visibility map) joined within " << fixed(bo.join_m, 1)
       << " m horizontally, storeys counted up each column of probes (buildings.h): "
       << r.buildings.size() << " buildings, " << storeys << " storeys, " << probes << " probes, " << rooms << " rooms with a designated probe, "
       << bytes << " B of records and maps.\n\n"
       << "| # | footprint (m) | height (m) | storeys: probes, bottom up | rooms | probes | KiB | sectors |\n"
          "|---:|---|---|---|---:|---:|---:|---:|\n";
    constexpr size_t kListed = 20;
    for (size_t i = 0; i < std::min(kListed, r.buildings.size()); ++i) {
      const BuildingStats& b = r.buildings[i];
      std::string st;
      for (size_t k = 0; k < b.storey_probes.size(); ++k) st += (k ? " " : "") + std::to_string(b.storey_probes[k]);
      md << "| " << i + 1 << " | " << fixed(b.min.x, 0) << ", " << fixed(b.min.y, 0) << " to " << fixed(b.max.x, 0) << ", "
         << fixed(b.max.y, 0) << " | " << fixed(b.bottom_z, 1) << " to " << fixed(b.top_z, 1) << " | " << b.storey_probes.size()
         << ": " << st << " | " << b.rooms << " | " << b.probes << " | " << fixed(double(b.bytes) / 1024.0, 1) << " | " << b.sectors
         << " |\n";
    }
    if (r.buildings.size() > kListed)
      md << "\n... and " << r.buildings.size() - kListed << " more (bake-report.json, \"buildings\").\n";
  }
  md << "\n## Time (seconds)\n\n| stage | seconds |\n|---|---|\n";
  md << "| wall | " << fixed(r.wall_s, 2) << " |\n| world geometry | " << fixed(r.geometry_s, 2) << " |\n| room search | " << fixed(r.rooms_s, 2) << " |\n| sectors (wall) | "
     << fixed(r.bake_s, 2) << " |\n| placement pass (LPRT) | " << fixed(r.placement_pass.seconds, 2) << " |\n| pack | "
     << fixed(r.pack_s, 2) << " |\n";
  if (r.peak_rss_bytes)
    md << "\nPeak resident memory of the process (the world's load included): " << formatBytes(r.peak_rss_bytes) << ".\n";
  if (!r.shards.empty()) {
    md << "\n## Shards (their status files: each one's last run)\n\n| shard | state | sectors | wall s | peak resident | host |\n|---|---|---:|---:|---:|---|\n";
    for (const ShardStatus& s : r.shards)
      md << "| " << s.index << "/" << s.count << " | " << stateName(s.state) << " | " << s.sectors << " | " << fixed(s.wall_s, 2) << " | "
         << (s.peak_rss_bytes ? formatBytes(s.peak_rss_bytes) : "-") << " | " << s.host << " |\n";
    if (const auto& b = balance)
      md << "\nThe slowest shard, " << b->slowest << ", took " << fixed(b->slowest_s, 2) << " s: " << fixed(b->slowest_s / b->mean_s, 2)
         << "x the mean of the done shards' " << fixed(b->mean_s, 2) << " s; the most memory a shard held: "
         << formatBytes(b->most_peak) << ".\n";
  }
  md << "\nSummed over sectors (each a wall time within its sector's task):\n\n| stage | seconds |\n|---|---|\n";
  md << "| gather | " << fixed(t_gather, 2) << " |\n| scene build | " << fixed(t_build, 2) << " |\n| placement | " << fixed(t_place, 2)
     << " |\n| probe rays | " << fixed(t_probe, 2) << " |\n| surface cache + bounces | " << fixed(t_surfel, 2) << " |\n| LPRT | "
     << fixed(t_lprt, 2) << " |\n| sun transfer | " << fixed(t_sun, 2) << " |\n| visibility maps | " << fixed(t_vis, 2)
     << " |\n| index grid | " << fixed(t_grid, 2) << " |\n";
  md << "\n## Settings\n\n| key | value |\n|---|---|\n";
  for (const auto& [k, v] : r.settings.describe()) md << "| " << k << " | " << v << " |\n";
  {
    std::ofstream f(markdown_path, std::ios::trunc);
    if (!f) return fail(markdown_path.string() + ": cannot open for writing");
    f << md.str();
    if (!f) return fail(markdown_path.string() + ": write failed");
  }
  return {};
}

}  // namespace drtv::baker
