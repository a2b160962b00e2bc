// drtv export-vdb <archive> -o grids.vdb [--time HH:MM] [--voxel-height m]
// Sky visibility, probe density and relit irradiance as OpenVDB grids (vdb.h).
#include <cstdio>
#include <memory>
#include <sstream>

#include "commands.h"
#include "drtv/eval/vdb.h"

namespace drtv::app {

Command registerExportVdb(CLI::App& app) {
  struct Options {
    std::string archive, output = "grids.vdb", time = "12:00";
    double voxel_height_m = 4.0;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("export-vdb", "Write sky visibility, probe density and relit irradiance as OpenVDB grids");
  sub->add_option("archive", o->archive, "Baked archive (.drtv)")->required();
  sub->add_option("-o,--output", o->output, "OpenVDB file to write")->capture_default_str();
  sub->add_option("--time", o->time, "Time of day HH:MM of the irradiance grid")->capture_default_str();
  sub->add_option("--voxel-height", o->voxel_height_m, "Vertical voxel size in metres")->check(CLI::Range(0.01, 1000.0))->capture_default_str();
  return {sub, [o]() -> Result<void> {
            auto hour = parseTimeOfDay(o->time);
            if (!hour) return std::unexpected(hour.error());
            eval::VdbExportOptions opts;
            opts.hour = *hour;
            opts.voxel_height_m = o->voxel_height_m;
            if (auto made = createParentFolder(o->output); !made) return std::unexpected(made.error());
            auto stats = eval::exportVdb(o->archive, o->output, opts);
            if (!stats) return std::unexpected(stats.error());
            std::printf("wrote %s: sky_visibility, probe_density, irradiance (%zu sectors, %zu probes, %zu active voxels)\n",
                        o->output.c_str(), stats->sectors, stats->probes, stats->active_voxels);
            return {};
          }, &o->archive};
}

}  // namespace drtv::app
