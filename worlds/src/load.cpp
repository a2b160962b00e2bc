// load.cpp — World files: the JSON world format (docs/world-format.md) and dispatch by
// extension (see drtv/worlds/load.h).
//
// nlohmann::json is the parser; its exceptions are caught here, at the adapter, and become
// Errors naming the file (STYLE.md, "Errors").
#include "drtv/worlds/load.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <functional>
#include <optional>
#include <set>
#include <sstream>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/gltf.h"
#include "gltf_import.h"
#include "drtv/worlds/island.h"
#include "town_detail.h"
#include "island_detail.h"
#include "noise.h"
#include "primitives.h"
#include "terrain.h"

// Propagates an Error out of the enclosing function returning a Result.
#define DRTV_TRY_DECL(name, expr)                                  \
  auto name##_result_ = (expr);                                    \
  if (!name##_result_) return std::unexpected(name##_result_.error()); \
  auto name = std::move(*name##_result_)
#define DRTV_TRY(expr)                                             \
  do {                                                             \
    auto drtv_r_ = (expr);                                         \
    if (!drtv_r_) return std::unexpected(drtv_r_.error());         \
  } while (0)

namespace drtv::worlds {
namespace {

using json = nlohmann::json;
using Ok = Result<bool>;  // a Result with nothing to carry

// Bytes a terrain vertex takes while it loads: heights (4) and mesh positions (12) and indices
// (24 per cell, ~1 cell per vertex), with the heightfield kept for vegetation beside the mesh.
constexpr double kTerrainLoadBytesPerVertex = 4 + 12 + 24 + 4;
// Bytes a vegetation copy takes: its Instance and the heap text of its name ("vegetation[0] 1234567").
constexpr uint64_t kInstanceLoadBytes = sizeof(Instance) + 32;

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string at(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

// The ground that vegetation stands on (a terrain or an island), in world coordinates.
struct Ground {
  Heightfield hf;
  double z_offset_m = 0;
  double heightAt(double x, double y) const { return hf.contains(x, y) ? hf.heightAt(x, y) + z_offset_m : 0.0; }
};

class Parser {
 public:
  Parser(std::filesystem::path base, std::string file) : base_(std::move(base)), file_(std::move(file)) {}

  Result<World> parse(const json& root);

 private:
  std::filesystem::path base_;
  std::string file_;
  World world_;
  std::optional<Ground> ground_;

  std::unexpected<Error> error(const std::string& path, const std::string& what) const {
    return fail(file_ + ": key '" + path + "': " + what);
  }

  Ok object(const json& j, const std::string& path, std::initializer_list<const char*> allowed) const {
    if (!j.is_object()) return error(path.empty() ? "(top level)" : path, std::string("expected object, got ") + j.type_name());
    for (const auto& item : j.items()) {
      if (std::none_of(allowed.begin(), allowed.end(), [&](const char* k) { return item.key() == k; }))
        return error(join(path, item.key()), "unknown key");
    }
    return true;
  }

  Result<double> number(const json& j, const std::string& path, double lo, double hi) const {
    if (!j.is_number()) return error(path, std::string("expected number, got ") + j.type_name());
    const double v = j.get<double>();
    if (!std::isfinite(v)) return error(path, "not a finite number");
    if (v < lo || v > hi) {
      std::ostringstream s;
      s << v << " out of range [" << lo << ", " << hi << "]";
      return error(path, s.str());
    }
    return v;
  }
  Result<double> optNumber(const json& obj, const char* key, const std::string& path, double fallback, double lo,
                           double hi) const {
    if (!obj.contains(key)) return fallback;
    return number(obj.at(key), join(path, key), lo, hi);
  }
  Result<double> reqNumber(const json& obj, const char* key, const std::string& path, double lo, double hi) const {
    if (!obj.contains(key)) return error(join(path, key), "required");
    return number(obj.at(key), join(path, key), lo, hi);
  }
  Result<uint64_t> optSeed(const json& obj, const char* key, const std::string& path, uint64_t fallback) const {
    if (!obj.contains(key)) return fallback;
    const json& j = obj.at(key);
    if (j.is_number_unsigned()) return j.get<uint64_t>();
    if (j.is_number_integer() && j.get<int64_t>() >= 0) return uint64_t(j.get<int64_t>());
    return error(join(path, key), std::string("expected non-negative integer, got ") + (j.is_number() ? "another number" : j.type_name()));
  }
  Result<std::string> optString(const json& obj, const char* key, const std::string& path, std::string fallback) const {
    if (!obj.contains(key)) return fallback;
    const json& j = obj.at(key);
    if (!j.is_string()) return error(join(path, key), std::string("expected string, got ") + j.type_name());
    return j.get<std::string>();
  }
  // A light's or an interior's name: the archive's manifest stores it with a 16-bit length.
  Result<std::string> optArchiveName(const json& obj, const std::string& path) const {
    DRTV_TRY_DECL(name, optString(obj, "name", path, path));
    if (name.size() > kMaxArchiveNameBytes)
      return error(join(path, "name"), std::to_string(name.size()) + " bytes; at most " + std::to_string(kMaxArchiveNameBytes));
    return name;
  }
  Result<std::string> reqString(const json& obj, const char* key, const std::string& path) const {
    if (!obj.contains(key)) return error(join(path, key), "required");
    return optString(obj, key, path, "");
  }
  // An array of N numbers in [lo, hi].
  template <int N>
  Result<glm::vec<N, double>> vec(const json& j, const std::string& path, double lo, double hi) const {
    const char* kExpected[] = {"", "", "expected array of 2 numbers", "expected array of 3 numbers", "expected array of 4 numbers"};
    if (!j.is_array() || j.size() != N) return error(path, kExpected[N]);
    glm::vec<N, double> v;
    for (int i = 0; i < N; ++i) {
      if (!j[size_t(i)].is_number()) return error(path, kExpected[N]);
      DRTV_TRY_DECL(x, number(j[size_t(i)], at(path, size_t(i)), lo, hi));
      v[i] = x;
    }
    return v;
  }
  template <int N>
  Result<glm::vec<N, double>> optVec(const json& obj, const char* key, const std::string& path, glm::vec<N, double> fallback,
                                     double lo, double hi) const {
    if (!obj.contains(key)) return fallback;
    return vec<N>(obj.at(key), join(path, key), lo, hi);
  }
  template <int N>
  Result<glm::vec<N, double>> reqVec(const json& obj, const char* key, const std::string& path, double lo, double hi) const {
    if (!obj.contains(key)) return error(join(path, key), "required");
    return vec<N>(obj.at(key), join(path, key), lo, hi);
  }
  Result<glm::vec3> albedo(const json& obj, const std::string& path, glm::vec3 fallback) const {
    DRTV_TRY_DECL(a, optVec<3>(obj, "albedo", path, glm::dvec3(fallback), 0.0, 1.0));
    return glm::vec3(a);
  }
  Result<InstanceClass> instanceClass(const json& obj, const std::string& path, InstanceClass fallback) const {
    if (!obj.contains("class")) return fallback;
    DRTV_TRY_DECL(name, optString(obj, "class", path, ""));
    for (int c = 0; c < 4; ++c)
      if (name == instanceClassName(static_cast<InstanceClass>(c))) return static_cast<InstanceClass>(c);
    return error(join(path, "class"), "unknown class '" + name + "' (terrain, static, vegetation, dynamic)");
  }
  // translation [x,y,z] m, rotation_z_deg, scale (number or [sx,sy,sz], > 0) -> T * Rz * S.
  Result<glm::dmat4> transform(const json& obj, const std::string& path) const {
    constexpr double kFar = 1e7;  // 10,000 km: anything further is a typo
    DRTV_TRY_DECL(t, optVec<3>(obj, "translation", path, glm::dvec3(0.0), -kFar, kFar));
    DRTV_TRY_DECL(r, optNumber(obj, "rotation_z_deg", path, 0.0, -3600.0, 3600.0));
    glm::dvec3 s(1.0);
    if (obj.contains("scale")) {
      const json& j = obj.at("scale");
      if (j.is_number()) {
        DRTV_TRY_DECL(k, number(j, join(path, "scale"), 1e-6, 1e6));
        s = glm::dvec3(k);
      } else {
        if (!j.is_array()) return error(join(path, "scale"), "expected number or array of 3 numbers");
        DRTV_TRY_DECL(v, vec<3>(j, join(path, "scale"), 1e-6, 1e6));
        s = v;
      }
    }
    glm::dmat4 m = glm::translate(glm::dmat4(1.0), t);
    m = glm::rotate(m, glm::radians(r), glm::dvec3(0, 0, 1));
    return glm::scale(m, s);
  }
  std::filesystem::path resolve(const std::string& p) const {
    const std::filesystem::path path(p);
    return path.is_absolute() ? path : base_ / path;
  }

  uint32_t addMesh(Mesh m) {
    world_.meshes.push_back(std::move(m));
    return uint32_t(world_.meshes.size() - 1);
  }

  // Refuses a terrain of `cells` x `cells` whose mesh would not fit in memory (memory_limit.h):
  // the heightfield (4 B a vertex), the mesh's positions (12 B) and indices (24 B a cell), plus
  // the copy the bake's geometry makes, are what loading it allocates. Names `key`.
  Ok terrainMemory(double cells, const std::string& key) const {
    const double vertices = (cells + 1) * (cells + 1);
    const auto bytes = uint64_t(vertices * kTerrainLoadBytesPerVertex);
    const std::string n = std::to_string(uint64_t(cells) + 1);
    if (auto ok = checkMemory(bytes, file_ + ": key '" + key + "'", "a terrain of " + n + " x " + n + " vertices"); !ok)
      return std::unexpected(ok.error());
    return true;
  }

  Ok terrain(const json& j);
  Ok island(const json& j);
  Ok town(const json& j);
  // A generated world (island, town) becomes the file's, under the file's name, with its ground.
  Ok adoptGenerated(Result<World> w, Ground g) {
    if (!w) return std::unexpected(w.error().context(file_));
    const std::string name = world_.name;
    world_ = std::move(*w);
    world_.name = name;
    ground_ = std::move(g);
    return true;
  }
  Ok primitives(const json& j);
  Ok gltfs(const json& j);
  Ok vegetation(const json& j);
  Ok lights(const json& j);
  Ok interiors(const json& j);
  Ok effects(const json& j);
  Ok sky(const json& j);
  Result<Gradient> gradient(const json& j, const std::string& path) const;
  // Appends a glTF file's meshes; returns the instances (not yet added) in the file's frame.
  Result<std::vector<Instance>> importGltf(const std::string& rel, const std::string& path, InstanceClass cls);
};

Result<World> Parser::parse(const json& root) {
  DRTV_TRY(object(root, "", {"name", "terrain", "island", "town", "primitives", "gltf", "vegetation", "lights", "interiors", "effects", "sky", "representation"}));
  DRTV_TRY_DECL(name, optString(root, "name", "", std::filesystem::path(file_).stem().string()));
  world_.name = name;
  if (root.contains("island") && root.contains("terrain")) return error("terrain", "cannot be combined with 'island' (the island has its own terrain)");
  if (root.contains("town") && (root.contains("terrain") || root.contains("island")))
    return error("town", "cannot be combined with 'terrain' or 'island' (the town has its own terrain)");
  if (root.contains("island")) DRTV_TRY(island(root.at("island")));
  if (root.contains("town")) DRTV_TRY(town(root.at("town")));
  if (root.contains("terrain")) DRTV_TRY(terrain(root.at("terrain")));
  if (root.contains("primitives")) DRTV_TRY(primitives(root.at("primitives")));
  if (root.contains("gltf")) DRTV_TRY(gltfs(root.at("gltf")));
  if (root.contains("vegetation")) DRTV_TRY(vegetation(root.at("vegetation")));
  if (root.contains("lights")) DRTV_TRY(lights(root.at("lights")));
  if (root.contains("interiors")) DRTV_TRY(interiors(root.at("interiors")));
  if (root.contains("sky")) DRTV_TRY(sky(root.at("sky")));
  if (root.contains("representation")) {
    const json& r = root.at("representation");
    if (!r.is_string()) return error("representation", std::string("expected string, got ") + r.type_name());
    const auto parsed = parseRepresentation(r.get<std::string>());
    if (!parsed) return error("representation", "'" + r.get<std::string>() + "': expected one of " + representationNames());
    world_.representation = *parsed;
  }
  emissiveLights(world_);
  if (root.contains("effects")) {
    DRTV_TRY(effects(root.at("effects")));
  } else {
    world_.effects = defaultEffects(world_);
    world_.effects_explicit = false;
  }
  return std::move(world_);
}

Ok Parser::terrain(const json& j) {
  const std::string path = "terrain";
  if (!j.is_object()) return error(path, std::string("expected object, got ") + j.type_name());
  DRTV_TRY_DECL(kind, reqString(j, "kind", path));
  Ground g;
  if (kind == "noise") {
    DRTV_TRY(object(j, path, {"kind", "size_m", "resolution_m", "height_m", "feature_m", "seed", "albedo", "translation"}));
    DRTV_TRY_DECL(size, optNumber(j, "size_m", path, 128.0, 1.0, 65536.0));
    DRTV_TRY_DECL(res, optNumber(j, "resolution_m", path, 2.0, 0.25, 1024.0));
    if (size / res > 8192) return error(join(path, "resolution_m"), "too fine for size_m (more than 8192 cells a side)");
    DRTV_TRY(terrainMemory(std::max(1.0, std::round(size / res)), join(path, "resolution_m")));
    DRTV_TRY_DECL(height, optNumber(j, "height_m", path, 0.0, 0.0, 10000.0));
    DRTV_TRY_DECL(feature, optNumber(j, "feature_m", path, 32.0, 0.01, 1e6));
    DRTV_TRY_DECL(seed, optSeed(j, "seed", path, 1));
    g.hf = noiseHeightfield(size, res, height, feature, seed);
  } else if (kind == "heightmap") {
    DRTV_TRY(object(j, path, {"kind", "path", "size_m", "height_m", "resolution_m", "albedo", "translation"}));
    DRTV_TRY_DECL(rel, reqString(j, "path", path));
    DRTV_TRY_DECL(size, reqNumber(j, "size_m", path, 1.0, 65536.0));
    DRTV_TRY_DECL(height, reqNumber(j, "height_m", path, 0.0, 10000.0));
    DRTV_TRY_DECL(res, optNumber(j, "resolution_m", path, 0.0, 0.0, 1024.0));
    if (res > 0 && size / res > 8192) return error(join(path, "resolution_m"), "too fine for size_m (more than 8192 cells a side)");
    if (res > 0) DRTV_TRY(terrainMemory(std::max(1.0, std::round(size / res)), join(path, "resolution_m")));
    auto hf = loadHeightmapPng(resolve(rel), size, height, res);
    if (!hf) return error(join(path, "path"), hf.error().message);
    g.hf = std::move(*hf);
  } else {
    return error(join(path, "kind"), "unknown kind '" + kind + "' (noise, heightmap)");
  }
  DRTV_TRY_DECL(alb, albedo(j, path, glm::vec3(0.2f, 0.45f, 0.15f)));
  DRTV_TRY_DECL(t, optVec<3>(j, "translation", path, glm::dvec3(0.0), -1e7, 1e7));
  g.hf.origin += glm::dvec2(t);
  g.z_offset_m = t.z;
  const uint32_t mesh = addMesh(heightfieldMesh(g.hf, "terrain", alb));
  world_.instances.push_back(Instance{mesh, glm::translate(glm::dmat4(1.0), glm::dvec3(g.hf.origin, t.z)), InstanceClass::kTerrain, "terrain"});
  ground_ = std::move(g);
  return true;
}

Ok Parser::island(const json& j) {
  const std::string path = "island";
  DRTV_TRY(object(j, path, {"size_km2", "seed", "grid_spacing_m", "max_height_m", "trees_per_km2", "trees_per_cluster",
                            "rocks_per_km2", "buildings_per_km2", "walls_per_km2", "interior_fraction"}));
  IslandOptions o;
  DRTV_TRY_DECL(size, optNumber(j, "size_km2", path, o.size_km2, 1e-4, 256.0));
  DRTV_TRY_DECL(seed, optSeed(j, "seed", path, o.seed));
  DRTV_TRY_DECL(spacing, optNumber(j, "grid_spacing_m", path, o.grid_spacing_m, 0.5, 64.0));
  DRTV_TRY_DECL(height, optNumber(j, "max_height_m", path, o.max_height_m, 0.0, 2000.0));
  DRTV_TRY_DECL(trees, optNumber(j, "trees_per_km2", path, o.trees_per_km2, 0.0, 1e5));
  DRTV_TRY_DECL(cluster, optNumber(j, "trees_per_cluster", path, o.trees_per_cluster, 1.0, 1000.0));
  DRTV_TRY_DECL(rocks, optNumber(j, "rocks_per_km2", path, o.rocks_per_km2, 0.0, 1e5));
  DRTV_TRY_DECL(buildings, optNumber(j, "buildings_per_km2", path, o.buildings_per_km2, 0.0, 1e5));
  DRTV_TRY_DECL(walls, optNumber(j, "walls_per_km2", path, o.walls_per_km2, 0.0, 1e5));
  DRTV_TRY_DECL(interior, optNumber(j, "interior_fraction", path, o.interior_fraction, 0.0, 1.0));
  o.size_km2 = size;
  o.seed = seed;
  o.grid_spacing_m = spacing;
  o.max_height_m = height;
  o.trees_per_km2 = trees;
  o.trees_per_cluster = cluster;
  o.rocks_per_km2 = rocks;
  o.buildings_per_km2 = buildings;
  o.walls_per_km2 = walls;
  o.interior_fraction = interior;
  Ground g;
  return adoptGenerated(generateIslandWithHeightfield(o, &g.hf), std::move(g));
}

Ok Parser::town(const json& j) {
  const std::string path = "town";
  DRTV_TRY(object(j, path, {"size_m", "seed", "block_m", "street_m", "min_storeys", "max_storeys", "min_storey_m", "max_storey_m",
                            "courtyard_fraction", "pair_fraction", "square_fraction", "arcade_fraction", "lit_room_fraction",
                            "lamp_intensity", "terrain_height_m", "grid_spacing_m"}));
  TownOptions o;
  DRTV_TRY_DECL(size, optNumber(j, "size_m", path, o.size_m, 64.0, 8192.0));
  DRTV_TRY_DECL(seed, optSeed(j, "seed", path, o.seed));
  DRTV_TRY_DECL(block, optNumber(j, "block_m", path, o.block_m, 40.0, 400.0));
  DRTV_TRY_DECL(street, optNumber(j, "street_m", path, o.street_m, 4.0, 372.0));
  DRTV_TRY_DECL(min_storeys, optNumber(j, "min_storeys", path, o.min_storeys, 1.0, 16.0));
  DRTV_TRY_DECL(max_storeys, optNumber(j, "max_storeys", path, o.max_storeys, 1.0, 16.0));
  if (min_storeys != std::floor(min_storeys)) return error(join(path, "min_storeys"), "must be a whole number");
  if (max_storeys != std::floor(max_storeys)) return error(join(path, "max_storeys"), "must be a whole number");
  DRTV_TRY_DECL(min_storey, optNumber(j, "min_storey_m", path, o.min_storey_m, 2.5, 4.0));
  DRTV_TRY_DECL(max_storey, optNumber(j, "max_storey_m", path, o.max_storey_m, 2.5, 4.0));
  DRTV_TRY_DECL(courtyard, optNumber(j, "courtyard_fraction", path, o.courtyard_fraction, 0.0, 1.0));
  DRTV_TRY_DECL(pair, optNumber(j, "pair_fraction", path, o.pair_fraction, 0.0, 1.0));
  DRTV_TRY_DECL(square, optNumber(j, "square_fraction", path, o.square_fraction, 0.0, 1.0));
  DRTV_TRY_DECL(arcade, optNumber(j, "arcade_fraction", path, o.arcade_fraction, 0.0, 1.0));
  DRTV_TRY_DECL(lit, optNumber(j, "lit_room_fraction", path, o.lit_room_fraction, 0.0, 1.0));
  DRTV_TRY_DECL(lamp, optNumber(j, "lamp_intensity", path, o.lamp_intensity, 1e-6, 1e4));
  DRTV_TRY_DECL(hills, optNumber(j, "terrain_height_m", path, o.terrain_height_m, 0.0, 100.0));
  DRTV_TRY_DECL(spacing, optNumber(j, "grid_spacing_m", path, o.grid_spacing_m, 1.0, 64.0));
  o.size_m = size, o.seed = seed, o.block_m = block, o.street_m = street;
  o.min_storeys = uint32_t(min_storeys), o.max_storeys = uint32_t(max_storeys);
  o.min_storey_m = min_storey, o.max_storey_m = max_storey;
  o.courtyard_fraction = courtyard, o.pair_fraction = pair, o.square_fraction = square, o.arcade_fraction = arcade;
  o.lit_room_fraction = lit, o.lamp_intensity = float(lamp), o.terrain_height_m = hills, o.grid_spacing_m = spacing;
  Ground g;
  return adoptGenerated(generateTownWithHeightfield(o, &g.hf), std::move(g));
}

Ok Parser::primitives(const json& j) {
  if (!j.is_array()) return error("primitives", std::string("expected array, got ") + j.type_name());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = at("primitives", i);
    const json& p = j[i];
    DRTV_TRY(object(p, path, {"name", "shape", "albedo", "class", "translation", "rotation_z_deg", "scale"}));
    DRTV_TRY_DECL(shape, reqString(p, "shape", path));
    DRTV_TRY_DECL(name, optString(p, "name", path, path));
    DRTV_TRY_DECL(alb, albedo(p, path, glm::vec3(0.5f)));
    DRTV_TRY_DECL(cls, instanceClass(p, path, InstanceClass::kStatic));
    DRTV_TRY_DECL(m, transform(p, path));
    Mesh mesh;
    if (shape == "plane") mesh = makePlane(name, alb);
    else if (shape == "box") mesh = makeBox(name, alb);
    else if (shape == "sphere") mesh = makeSphere(name, alb, 24, 12);
    else return error(join(path, "shape"), "unknown shape '" + shape + "' (plane, box, sphere)");
    const uint32_t id = addMesh(std::move(mesh));
    world_.instances.push_back(Instance{id, m, cls, name});
  }
  return true;
}

Result<std::vector<Instance>> Parser::importGltf(const std::string& rel, const std::string& path, InstanceClass cls) {
  // Emission stays on the meshes: parse() makes the lights once every instance is placed.
  auto w = loadGltfMeshes(resolve(rel), cls);
  if (!w) return std::unexpected(w.error().context(file_ + ": key '" + path + "'"));
  world_.materials += w->materials;
  const auto offset = uint32_t(world_.meshes.size());
  for (Mesh& m : w->meshes) world_.meshes.push_back(std::move(m));
  for (Instance& inst : w->instances) inst.mesh += offset;
  world_.notes.insert(world_.notes.end(), w->notes.begin(), w->notes.end());
  return std::move(w->instances);
}

Ok Parser::gltfs(const json& j) {
  if (!j.is_array()) return error("gltf", std::string("expected array, got ") + j.type_name());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = at("gltf", i);
    const json& g = j[i];
    DRTV_TRY(object(g, path, {"name", "path", "class", "translation", "rotation_z_deg", "scale"}));
    DRTV_TRY_DECL(rel, reqString(g, "path", path));
    DRTV_TRY_DECL(name, optString(g, "name", path, rel));
    DRTV_TRY_DECL(cls, instanceClass(g, path, InstanceClass::kStatic));
    DRTV_TRY_DECL(m, transform(g, path));
    DRTV_TRY_DECL(instances, importGltf(rel, join(path, "path"), cls));
    for (Instance& inst : instances) {
      inst.transform = m * inst.transform;
      inst.name = name + ": " + inst.name;
      world_.instances.push_back(std::move(inst));
    }
  }
  return true;
}

Ok Parser::vegetation(const json& j) {
  if (!j.is_array()) return error("vegetation", std::string("expected array, got ") + j.type_name());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = at("vegetation", i);
    const json& v = j[i];
    DRTV_TRY(object(v, path, {"name", "mesh", "count", "seed", "region", "scale", "class"}));
    DRTV_TRY_DECL(name, optString(v, "name", path, path));
    DRTV_TRY_DECL(count_d, reqNumber(v, "count", path, 0.0, 1e7));
    if (count_d != std::floor(count_d)) return error(join(path, "count"), "expected an integer");
    const auto count = static_cast<size_t>(count_d);
    DRTV_TRY_DECL(seed, optSeed(v, "seed", path, 1));
    DRTV_TRY_DECL(scale, optVec<2>(v, "scale", path, glm::dvec2(1.0), 1e-3, 1e3));
    if (scale.x > scale.y) return error(join(path, "scale"), "expected [min, max] with min <= max");
    DRTV_TRY_DECL(cls, instanceClass(v, path, InstanceClass::kVegetation));
    // Region: default the ground's extent.
    glm::dvec2 lo(0.0), hi(0.0);
    if (v.contains("region")) {
      const std::string rpath = join(path, "region");
      DRTV_TRY(object(v.at("region"), rpath, {"min", "max"}));
      DRTV_TRY_DECL(a, reqVec<2>(v.at("region"), "min", rpath, -1e7, 1e7));
      DRTV_TRY_DECL(b, reqVec<2>(v.at("region"), "max", rpath, -1e7, 1e7));
      if (!(a.x < b.x && a.y < b.y)) return error(rpath, "expected min < max in x and y");
      lo = a;
      hi = b;
    } else if (ground_) {
      lo = ground_->hf.origin;
      hi = lo + ground_->hf.spacing_m * glm::dvec2(ground_->hf.nx - 1, ground_->hf.ny - 1);
    } else {
      return error(join(path, "region"), "required when the world has no terrain or island");
    }
    // The mesh: a built-in primitive standing on z = 0, or a glTF file.
    if (!v.contains("mesh")) return error(join(path, "mesh"), "required");
    const json& mj = v.at("mesh");
    const std::string mpath = join(path, "mesh");
    DRTV_TRY(object(mj, mpath, {"primitive", "gltf", "albedo", "size"}));
    std::vector<Instance> prototype;
    if (mj.contains("primitive") == mj.contains("gltf")) return error(mpath, "expected exactly one of 'primitive' or 'gltf'");
    if (mj.contains("primitive")) {
      DRTV_TRY_DECL(shape, optString(mj, "primitive", mpath, ""));
      DRTV_TRY_DECL(alb, albedo(mj, mpath, glm::vec3(0.15f, 0.4f, 0.1f)));
      DRTV_TRY_DECL(size, optVec<3>(mj, "size", mpath, glm::dvec3(1.0), 1e-3, 1e4));
      Mesh mesh;
      if (shape == "plane") mesh = makePlane(name, alb);
      else if (shape == "box") mesh = makeBox(name, alb);
      else if (shape == "sphere") mesh = makeSphere(name, alb, 12, 6);
      else return error(join(mpath, "primitive"), "unknown shape '" + shape + "' (plane, box, sphere)");
      for (glm::vec3& p : mesh.positions) p = (p + glm::vec3(0, 0, shape == "plane" ? 0.f : 0.5f)) * glm::vec3(size);
      prototype.push_back(Instance{addMesh(std::move(mesh)), glm::dmat4(1.0), cls, name});
    } else {
      if (mj.contains("albedo") || mj.contains("size")) return error(mpath, "'albedo' and 'size' apply to 'primitive' meshes only");
      DRTV_TRY_DECL(rel, optString(mj, "gltf", mpath, ""));
      DRTV_TRY_DECL(instances, importGltf(rel, join(mpath, "gltf"), cls));
      prototype = std::move(instances);
    }
    // Every copy is an Instance (its transform and name): refuse a count that cannot fit before
    // allocating gigabytes one push_back at a time (memory_limit.h).
    const uint64_t copies = uint64_t(count) * prototype.size();
    if (auto ok = checkMemory(copies * kInstanceLoadBytes, file_ + ": key '" + join(path, "count") + "'",
                              std::to_string(copies) + " vegetation instances");
        !ok)
      return std::unexpected(ok.error());
    world_.instances.reserve(world_.instances.size() + copies);
    for (size_t k = 0; k < count; ++k) {
      const double x = noise::uniform(seed, i, k, 0, lo.x, hi.x), y = noise::uniform(seed, i, k, 1, lo.y, hi.y);
      const double s = noise::uniform(seed, i, k, 2, scale.x, scale.y);
      const double yaw = noise::uniform(seed, i, k, 3, 0.0, 2.0 * 3.14159265358979323846);
      const double z = ground_ ? ground_->heightAt(x, y) : 0.0;
      glm::dmat4 m = glm::translate(glm::dmat4(1.0), glm::dvec3(x, y, z));
      m = glm::scale(glm::rotate(m, yaw, glm::dvec3(0, 0, 1)), glm::dvec3(s));
      for (const Instance& p : prototype)
        world_.instances.push_back(Instance{p.mesh, m * p.transform, cls, name + " " + std::to_string(k)});
    }
  }
  return true;
}

Ok Parser::lights(const json& j) {
  if (!j.is_array()) return error("lights", std::string("expected array, got ") + j.type_name());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = at("lights", i);
    DRTV_TRY(object(j[i], path, {"name", "position", "intensity", "radius_m", "path"}));
    PointLight l;
    DRTV_TRY_DECL(name, optArchiveName(j[i], path));
    DRTV_TRY_DECL(pos, reqVec<3>(j[i], "position", path, -1e7, 1e7));
    DRTV_TRY_DECL(intensity, optVec<3>(j[i], "intensity", path, glm::dvec3(1.0), 0.0, kMaxColourValue));
    DRTV_TRY_DECL(radius, optNumber(j[i], "radius_m", path, 10.0, 1e-3, kMaxLightRadiusM));  // 1e-3 rounds up to kMinLightRadiusM
    l.name = name;
    l.position = pos;
    l.intensity = glm::vec3(intensity);
    l.radius_m = float(radius);
    LightPath motion;
    if (j[i].contains("path")) {
      // {"keys": [{"t_s", "position", "intensity"?, "radius_m"?}, ...], "loop": bool}; a key's
      // intensity and radius default to the light's.
      const std::string mp = join(path, "path");
      const json& pj = j[i].at("path");
      DRTV_TRY(object(pj, mp, {"keys", "loop"}));
      if (!pj.contains("keys")) return error(join(mp, "keys"), "required");
      const json& keys = pj.at("keys");
      if (!keys.is_array()) return error(join(mp, "keys"), std::string("expected array, got ") + keys.type_name());
      if (keys.size() < 2) return error(join(mp, "keys"), "a path needs at least 2 keys (a light that stays put needs no path)");
      if (keys.size() > 100000) return error(join(mp, "keys"), "more than 100000 keys");
      for (size_t k = 0; k < keys.size(); ++k) {
        const std::string kp = at(join(mp, "keys"), k);
        DRTV_TRY(object(keys[k], kp, {"t_s", "position", "intensity", "radius_m"}));
        LightKey key;
        DRTV_TRY_DECL(t, reqNumber(keys[k], "t_s", kp, -1e9, 1e9));
        DRTV_TRY_DECL(kpos, reqVec<3>(keys[k], "position", kp, -1e7, 1e7));
        DRTV_TRY_DECL(kint, optVec<3>(keys[k], "intensity", kp, intensity, 0.0, 1e9));
        DRTV_TRY_DECL(krad, optNumber(keys[k], "radius_m", kp, radius, 1e-3, 1e5));
        if (k > 0 && !(t > motion.keys.back().t_s)) return error(join(kp, "t_s"), "must be greater than the previous key's");
        key.t_s = t;
        key.position = kpos;
        key.intensity = glm::vec3(kint);
        key.radius_m = float(krad);
        motion.keys.push_back(key);
      }
      if (pj.contains("loop")) {
        if (!pj.at("loop").is_boolean()) return error(join(mp, "loop"), std::string("expected boolean, got ") + pj.at("loop").type_name());
        motion.loop = pj.at("loop").get<bool>();
      }
      // The bake and the manifest keep the light where its path starts.
      const PointLight first = lightAt(l, motion, motion.keys.front().t_s);
      l.position = first.position, l.intensity = first.intensity, l.radius_m = first.radius_m;
    }
    world_.lights.push_back(l);
    world_.light_paths.push_back(std::move(motion));
  }
  return true;
}

Ok Parser::interiors(const json& j) {
  if (!j.is_array()) return error("interiors", std::string("expected array, got ") + j.type_name());
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = at("interiors", i);
    DRTV_TRY(object(j[i], path, {"name", "min", "max", "probe", "blend_m"}));
    InteriorVolume v;
    DRTV_TRY_DECL(name, optArchiveName(j[i], path));
    DRTV_TRY_DECL(lo, reqVec<3>(j[i], "min", path, -1e7, 1e7));
    DRTV_TRY_DECL(hi, reqVec<3>(j[i], "max", path, -1e7, 1e7));
    DRTV_TRY_DECL(probe, reqVec<3>(j[i], "probe", path, -1e7, 1e7));
    DRTV_TRY_DECL(blend, optNumber(j[i], "blend_m", path, 1.0, 0.0, kMaxBlendDistanceM));
    if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z)) return error(join(path, "max"), "expected max > min on every axis");
    if (glm::any(glm::lessThan(probe, lo)) || glm::any(glm::greaterThan(probe, hi)))
      return error(join(path, "probe"), "the designated probe must lie inside [min, max]");
    v.name = name;
    v.min = lo;
    v.max = hi;
    v.probe_position = probe;
    v.blend_distance_m = float(blend);
    world_.interiors.push_back(v);
  }
  return true;
}

Ok Parser::effects(const json& j) {
  if (!j.is_array()) return error("effects", std::string("expected array of effect names, got ") + j.type_name());
  uint32_t mask = 0;
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_string()) return error(at("effects", i), std::string("expected string, got ") + j[i].type_name());
    const auto e = parseEffect(j[i].get<std::string>());
    if (!e) return error(at("effects", i), "unknown effect '" + j[i].get<std::string>() + "'");
    mask |= *e;
  }
  world_.effects = mask;
  world_.effects_explicit = true;
  return true;
}

Result<Gradient> Parser::gradient(const json& j, const std::string& path) const {
  if (!j.is_array() || j.empty()) return error(path, "expected non-empty array of [hour, r, g, b]");
  Gradient g;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string kpath = at(path, i);
    if (!j[i].is_array() || j[i].size() != 4) return error(kpath, "expected [hour, r, g, b]");
    DRTV_TRY_DECL(hour, number(j[i][0], at(kpath, 0), 0.0, std::nextafter(24.0, 0.0)));
    glm::vec3 value;
    for (int c = 0; c < 3; ++c) {
      DRTV_TRY_DECL(x, number(j[i][size_t(c) + 1], at(kpath, size_t(c) + 1), 0.0, kMaxColourValue));
      value[c] = float(x);
    }
    if (!g.keys.empty() && !(hour > g.keys.back().hour)) return error(at(kpath, 0), "hours must increase strictly");
    g.keys.push_back(ColorKey{float(hour), value});
  }
  return g;
}

Ok Parser::sky(const json& j) {
  const std::string path = "sky";
  DRTV_TRY(object(j, path, {"latitude_deg", "declination_deg", "north_deg", "ground_radiance_scale", "sun_irradiance",
                            "sky_zenith", "sky_horizon"}));
  Sky& s = world_.sky;
  DRTV_TRY_DECL(lat, optNumber(j, "latitude_deg", path, glm::degrees(s.latitude_rad), -90.0, 90.0));
  DRTV_TRY_DECL(dec, optNumber(j, "declination_deg", path, glm::degrees(s.declination_rad), -23.5, 23.5));
  DRTV_TRY_DECL(north, optNumber(j, "north_deg", path, glm::degrees(s.north_rad), -360.0, 360.0));
  DRTV_TRY_DECL(ground, optNumber(j, "ground_radiance_scale", path, s.ground_radiance_scale, 0.0, 1.0));
  s.latitude_rad = glm::radians(lat);
  s.declination_rad = glm::radians(dec);
  s.north_rad = glm::radians(north);
  s.ground_radiance_scale = float(ground);
  const std::pair<const char*, Gradient*> gradients[] = {
      {"sun_irradiance", &s.sun_irradiance}, {"sky_zenith", &s.sky_zenith}, {"sky_horizon", &s.sky_horizon}};
  for (const auto& [key, target] : gradients) {
    if (!j.contains(key)) continue;
    DRTV_TRY_DECL(g, gradient(j.at(key), join(path, key)));
    *target = std::move(g);
  }
  return true;
}

std::string lowerExtension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace

// The key path of the first key that repeats within one object ("sky.latitude_deg"), found while
// parsing: nlohmann::json keeps the last of duplicate keys without a word, so a world file with
// two "terrain" objects would silently bake one of them.
class DuplicateKeyFinder {
 public:
  bool operator()(int /*depth*/, json::parse_event_t event, const json& parsed) {
    if (!duplicate_.empty()) return true;
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        countElement();
        frames_.push_back(Frame{event == json::parse_event_t::array_start, 0, {}, {}});
        break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!frames_.empty()) frames_.pop_back();
        break;
      case json::parse_event_t::key: {
        if (frames_.empty() || frames_.back().array) break;
        Frame& f = frames_.back();
        f.key = parsed.is_string() ? parsed.get<std::string>() : parsed.dump();
        if (!f.keys.insert(f.key).second) duplicate_ = path();
        break;
      }
      case json::parse_event_t::value:
        countElement();
        break;
    }
    return true;
  }
  // "" when every object's keys were unique.
  const std::string& duplicate() const { return duplicate_; }

 private:
  struct Frame {
    bool array = false;
    size_t elements = 0;          // arrays: elements seen so far
    std::set<std::string> keys;   // objects: keys seen so far
    std::string key;              // objects: the key being read
  };
  void countElement() {
    if (!frames_.empty() && frames_.back().array) ++frames_.back().elements;
  }
  std::string path() const {
    std::string p;
    for (const Frame& f : frames_) {
      if (f.array) p += "[" + std::to_string(f.elements - 1) + "]";  // the element being read
      else p += (p.empty() ? "" : ".") + f.key;
    }
    return p;
  }
  std::vector<Frame> frames_;
  std::string duplicate_;
};

Result<World> parseWorldJson(std::string_view text, const std::filesystem::path& base_dir, const std::string& file_name) {
  try {
    DuplicateKeyFinder duplicates;
    json root = json::parse(text.begin(), text.end(), std::ref(duplicates));
    if (!duplicates.duplicate().empty())
      return fail(file_name + ": key '" + duplicates.duplicate() + "': duplicate key (JSON objects must not repeat a key)");
    Parser parser(base_dir, file_name);
    return parser.parse(root);
  } catch (const json::parse_error& e) {
    return fail(file_name + ": JSON syntax error at byte " + std::to_string(e.byte) + ": " + e.what());
  } catch (const std::exception& e) {  // type errors cannot happen after our checks; be safe anyway
    return fail(file_name + ": " + e.what());
  }
}

Result<World> loadWorld(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string ext = lowerExtension(path);
  if (ext == ".gltf" || ext == ".glb") return loadGltf(path, InstanceClass::kStatic);
  if (ext != ".json") return fail(file + ": unknown world file type '" + ext + "' (expected .json, .gltf or .glb)");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(file + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return fail(file + ": read error");
  return parseWorldJson(text.str(), path.parent_path(), file);
}

}  // namespace drtv::worlds
