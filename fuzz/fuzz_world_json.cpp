// fuzz_world_json.cpp — libFuzzer target for the JSON world loader (worlds/src/load.cpp,
// docs/world-format.md).
//
// The input is a world file's text. Relative paths in it resolve against fuzz/data/ (a tiny
// glTF and heightmap, DRTV_FUZZ_DATA_DIR), so references to other files are exercised too.
// Properties: never an abort, an out-of-bounds read, a leak or UB; every error names the file;
// what loads is a World whose instances name existing meshes and whose triangles index
// existing vertices.
//
// Budget: the format lets a few bytes ask for a great deal of work by design (a 8192 x 8192
// terrain, 1e7 trees, a 256 km^2 island). Those are documented maxima, not bugs in the parser,
// and at 10^4 runs/s they would only make the fuzzer report out-of-memory and timeouts. Inputs
// whose sizes ask for more than the small budget below are therefore skipped before loading;
// what they cost in a real load is issue 17's "memory as an input limit" item, tested apart.
// After meshoptimizer's tools/codecfuzz.cpp. Run: docs/fuzzing.md.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "drtv/worlds/load.h"

namespace {

using json = nlohmann::json;

constexpr double kMaxCellsPerSide = 256;    // terrain and island grids
constexpr double kMaxGeneratedObjects = 512;  // vegetation instances, island trees/rocks/houses

// The number at obj[key] if it is one, else `fallback`.
double numberOr(const json& obj, const char* key, double fallback) {
  if (!obj.is_object()) return fallback;
  const auto it = obj.find(key);
  return it != obj.end() && it->is_number() ? it->get<double>() : fallback;
}

// True when loading `root` could need more than the budget: the loader decides validity, this
// only looks at the numbers that multiply work.
bool overBudget(const json& root) {
  if (!root.is_object()) return false;
  if (const auto t = root.find("terrain"); t != root.end() && t->is_object()) {
    const double size = numberOr(*t, "size_m", 128.0), res = numberOr(*t, "resolution_m", 2.0);
    if (!(std::abs(size) <= kMaxCellsPerSide * std::abs(res))) return true;
  }
  if (const auto i = root.find("island"); i != root.end()) {
    const double km2 = numberOr(*i, "size_km2", 1.0), spacing = numberOr(*i, "grid_spacing_m", 4.0);
    const double side_m = std::sqrt(std::abs(km2) * 1e6);
    if (!(side_m <= kMaxCellsPerSide * std::abs(spacing))) return true;
    for (const char* density : {"trees_per_km2", "rocks_per_km2", "buildings_per_km2", "walls_per_km2"})
      if (!(std::abs(numberOr(*i, density, 4000.0) * km2) <= kMaxGeneratedObjects)) return true;
  }
  if (const auto v = root.find("vegetation"); v != root.end() && v->is_array()) {
    double total = 0;
    for (const json& entry : *v) total += std::abs(numberOr(entry, "count", 0.0));
    if (!(total <= kMaxGeneratedObjects)) return true;
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const json root = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!root.is_discarded() && overBudget(root)) return 0;
  const auto world = drtv::worlds::parseWorldJson(text, DRTV_FUZZ_DATA_DIR, "fuzz.json");
  if (!world) {
    DRTV_CHECK_EQ(world.error().message.rfind("fuzz.json: ", 0), 0u);
    return 0;
  }
  for (const auto& instance : world->instances) DRTV_CHECK_LT(instance.mesh, world->meshes.size());
  for (const auto& mesh : world->meshes) {
    DRTV_CHECK_EQ(mesh.indices.size() % 3, 0u);
    for (uint32_t i : mesh.indices) DRTV_CHECK_LT(i, mesh.positions.size());
  }
  return 0;
}
