// The drtv program's subcommands. Each lives in its own cmd_<name>.cpp and registers itself on
// the CLI11 app; main.cpp lists the registrations, parses, and maps errors to exit codes:
//   0 success; 1 a failure ("drtv: error: <file>: <what>" on stderr); 2 a usage error.
#pragma once

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

#include <glm/glm.hpp>

#include "drtv/raytrace/world_geometry.h"
#include "drtv/formats/error.h"

namespace drtv::app {

// What a subcommand runs once its options are parsed: an Error becomes exit code 1.
using Action = std::function<Result<void>()>;

// Adds a subcommand to `app` and returns the action to run when it is chosen. The options it
// binds must outlive the parse: keep them in static or heap storage owned by the registration.
struct Command {
  CLI::App* sub = nullptr;
  Action run;
  const std::string* input = nullptr;  // the file the subcommand reads, for a last-resort error
};

Command registerInfo(CLI::App& app);
Command registerBake(CLI::App& app);
Command registerQuery(CLI::App& app);
Command registerBenchBake(CLI::App& app);
Command registerMap(CLI::App& app);
Command registerFly(CLI::App& app);
Command registerRender(CLI::App& app);
Command registerAccuracy(CLI::App& app);
Command registerExportVdb(CLI::App& app);
Command registerFarm(CLI::App& app);

// A time of day "HH:MM" (00:00 to 23:59) as hours; the error names `flag` and the text.
Result<double> parseTimeOfDay(const std::string& text, const std::string& flag = "--time");

// An integer option; the error names `flag` and the text.
Result<int> parseInt(const std::string& text, const std::string& flag);
// "x0:x1,y0:y1": inclusive, non-empty ranges of sector keys (--sectors).
Result<raytrace::SectorRange> parseSectors(const std::string& text);
// "x,y,z": three finite numbers; the error names `flag` and the text.
Result<glm::dvec3> parseVec3(const std::string& text, const std::string& flag);

// Creates the folder that will hold the output file `path` (and its parents), so that
// `-o newdir/x.png` works; the error names the folder. A bare file name needs nothing.
Result<void> createParentFolder(const std::string& path);

// CLI11 validators (a rejected value is a usage error, exit 2). A number in [lo, hi], or in
// (lo, hi] when `lo_open`, and finite: CLI::Range lets NaN through (every comparison is false).
CLI::Validator finiteRange(double lo, double hi, bool lo_open = false);
// "x,y,z" as parseVec3 reads it, and not the zero vector (a direction to normalise).
CLI::Validator nonZeroVec3();

// True when stderr is a terminal and CI is not set: long work may draw progress there.
bool showProgress();

}  // namespace drtv::app
