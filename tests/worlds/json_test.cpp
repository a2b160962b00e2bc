// Tests of the JSON world format (docs/world-format.md) and loadWorld's dispatch.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "drtv/image/image.h"

#include "drtv/worlds/load.h"
#include "drtv/worlds/summary.h"


namespace drtv::worlds {
namespace {

// Float stored from a double literal: one float rounding.
constexpr double kFloatTolerance = 1e-6;

Result<World> parse(const std::string& text) { return parseWorldJson(text, DRTV_SOURCE_DIR "/worlds", "worlds/x.json"); }

// Expects `text` to fail with a message that starts with the file and contains `fragment`.
void expectError(const std::string& text, const std::string& fragment) {
  const auto w = parse(text);
  ASSERT_FALSE(w.has_value()) << text;
  EXPECT_EQ(w.error().message.rfind("worlds/x.json: ", 0), 0u) << w.error().message;
  EXPECT_NE(w.error().message.find(fragment), std::string::npos) << "message: " << w.error().message << "\nwanted: " << fragment;
}

TEST(WorldJson, EmptyObjectIsAnEmptyWorldWithDefaults) {
  const auto w = parse("{}");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->name, "x");
  EXPECT_TRUE(w->instances.empty());
  EXPECT_FALSE(w->effects_explicit);
  EXPECT_EQ(w->effects, defaultEffects(*w));
  EXPECT_EQ(w->sky.sun_irradiance.at(12.0), Sky::tropicalDefault().sun_irradiance.at(12.0));
}

TEST(WorldJson, RejectsUnknownKeyNamingIt) {
  expectError(R"({"colour": 1})", "key 'colour': unknown key");
  expectError(R"({"primitives": [{"shape": "box"}, {"shape": "box", "albedoo": [1,1,1]}]})", "key 'primitives[1].albedoo': unknown key");
  expectError(R"({"sky": {"sun": []}})", "key 'sky.sun': unknown key");
  expectError(R"({"terrain": {"kind": "noise", "octaves": 3}})", "key 'terrain.octaves': unknown key");
  expectError(R"({"vegetation": [{"count": 1, "region": {"min": [0,0], "max": [1,1], "z": 0}, "mesh": {"primitive": "box"}}]})",
              "key 'vegetation[0].region.z': unknown key");
  expectError(R"({"island": {"size": 1}})", "key 'island.size': unknown key");
}

TEST(WorldJson, RejectsWrongTypesNamingTheKey) {
  expectError(R"({"primitives": [{"shape": "box"}, {"shape": "box"}, {"shape": "box", "albedo": "red"}]})",
              "key 'primitives[2].albedo': expected array of 3 numbers");
  expectError(R"({"primitives": [{"shape": "box", "albedo": [1, 1]}]})", "key 'primitives[0].albedo': expected array of 3 numbers");
  expectError(R"({"primitives": {"shape": "box"}})", "key 'primitives': expected array");
  expectError(R"({"name": 3})", "key 'name': expected string");
  expectError(R"({"lights": [{"position": [0, 0, "1"]}]})", "key 'lights[0].position': expected array of 3 numbers");
  expectError(R"({"sky": {"latitude_deg": "north"}})", "key 'sky.latitude_deg': expected number");
  expectError(R"({"effects": "sun_bounce"})", "key 'effects': expected array");
  expectError(R"({"effects": [1]})", "key 'effects[0]': expected string");
  expectError(R"({"terrain": {"kind": "noise", "seed": -1}})", "key 'terrain.seed': expected non-negative integer");
  expectError(R"({"primitives": [{"shape": "box", "scale": "big"}]})", "key 'primitives[0].scale'");
  expectError(R"([1, 2])", "key '(top level)': expected object");
}

TEST(WorldJson, RejectsOutOfRangeValuesNamingTheKey) {
  expectError(R"({"primitives": [{"shape": "box", "albedo": [1.5, 0, 0]}]})", "key 'primitives[0].albedo[0]': 1.5 out of range [0, 1]");
  expectError(R"({"primitives": [{"shape": "box", "albedo": [0.5, -0.1, 0]}]})", "key 'primitives[0].albedo[1]'");
  expectError(R"({"lights": [{"position": [0, 0, 1], "intensity": [1, -1, 1]}]})", "key 'lights[0].intensity[1]'");
  expectError(R"({"lights": [{"position": [0, 0, 1], "radius_m": 0}]})", "key 'lights[0].radius_m'");
  expectError(R"({"primitives": [{"shape": "box", "scale": [1, 0, 1]}]})", "key 'primitives[0].scale[1]'");
  expectError(R"({"primitives": [{"shape": "box", "translation": [0, 0, 1e400]}]})", "worlds/x.json");  // JSON overflow
  expectError(R"({"interiors": [{"min": [0,0,0], "max": [1,1,1], "probe": [2, 0.5, 0.5]}]})", "key 'interiors[0].probe'");
  expectError(R"({"interiors": [{"min": [0,0,0], "max": [1,0,1], "probe": [0.5, 0, 0.5]}]})", "key 'interiors[0].max'");
  expectError(R"({"sky": {"sun_irradiance": [[12, 1, 1, 1], [6, 1, 1, 1]]}})", "key 'sky.sun_irradiance[1][0]': hours must increase");
  expectError(R"({"sky": {"sky_zenith": [[24, 1, 1, 1]]}})", "key 'sky.sky_zenith[0][0]'");
  expectError(R"({"sky": {"sky_horizon": [[1, 1, 1]]}})", "key 'sky.sky_horizon[0]': expected [hour, r, g, b]");
  expectError(R"({"sky": {"sky_horizon": []}})", "key 'sky.sky_horizon'");
  expectError(R"({"island": {"size_km2": 0}})", "key 'island.size_km2'");
}

TEST(WorldJson, RejectsBadNamesAndCombinations) {
  expectError(R"({"primitives": [{"shape": "cone"}]})", "key 'primitives[0].shape': unknown shape 'cone'");
  expectError(R"({"primitives": [{"shape": "box", "class": "tree"}]})", "key 'primitives[0].class': unknown class 'tree'");
  expectError(R"({"primitives": [{"albedo": [1, 1, 1]}]})", "key 'primitives[0].shape': required");
  expectError(R"({"effects": ["sun_bounce", "glow"]})", "key 'effects[1]': unknown effect 'glow'");
  expectError(R"({"terrain": {"kind": "voxel"}})", "key 'terrain.kind': unknown kind 'voxel'");
  expectError(R"({"island": {}, "terrain": {"kind": "noise"}})", "key 'terrain': cannot be combined");
  expectError(R"({"gltf": [{"path": "missing.glb"}]})", "key 'gltf[0].path'");
  expectError(R"({"vegetation": [{"count": 3, "mesh": {"primitive": "box"}}]})", "key 'vegetation[0].region': required");
  expectError(R"({"vegetation": [{"count": 1.5, "region": {"min": [0,0], "max": [1,1]}, "mesh": {"primitive": "box"}}]})",
              "key 'vegetation[0].count': expected an integer");
  expectError(R"({"vegetation": [{"count": 1, "region": {"min": [0,0], "max": [1,1]}, "mesh": {}}]})",
              "key 'vegetation[0].mesh': expected exactly one");
  expectError(R"({"terrain": {"kind": "heightmap", "path": "nope.png", "size_m": 10, "height_m": 1}})", "key 'terrain.path'");
}

// The archive stores light and interior names with a 16-bit length: a longer one is an error
// naming the key, not an abort when the bake writes its manifest.
TEST(WorldJson, ALightOrInteriorNameLongerThanTheArchiveStoresIsAnError) {
  const std::string big(70000, 'x');
  expectError(R"({"lights": [{"name": ")" + big + R"(", "position": [0, 0, 5]}]})", "key 'lights[0].name': 70000 bytes; at most 65535");
  expectError(R"({"interiors": [{"name": ")" + big + R"(", "min": [0, 0, 0], "max": [4, 4, 3], "probe": [2, 2, 1]}]})",
              "key 'interiors[0].name': 70000 bytes; at most 65535");
  const std::string most(65535, 'y');
  auto w = parse(R"({"lights": [{"name": ")" + most + R"(", "position": [0, 0, 5]}]})");
  ASSERT_TRUE(w.has_value()) << w.error().message.substr(0, 200);
  EXPECT_EQ(w->lights.at(0).name.size(), 65535u);
}

TEST(WorldJson, AHeightmapThatIsNoRegularFileIsAnErrorNotAnEndlessRead) {
  // /dev/zero never ends: read whole, as the heightmap loader reads files, it would exhaust memory.
  expectError(R"({"terrain": {"kind": "heightmap", "path": "/dev/zero", "size_m": 10, "height_m": 1}})",
              "key 'terrain.path': /dev/zero: cannot open heightmap: not a regular file");
  expectError(R"({"terrain": {"kind": "heightmap", "path": ".", "size_m": 10, "height_m": 1}})", "not a regular file");
}

TEST(WorldJson, RejectsSyntaxErrorsWithFileName) {
  expectError(R"({"name": )", "JSON syntax error");
  expectError("", "JSON syntax error");
}

TEST(WorldJson, ParsesPrimitivesWithTransformAlbedoAndClass) {
  const auto w = parse(R"({"primitives": [
      {"name": "wall", "shape": "box", "albedo": [0.8, 0.1, 0.1], "class": "static",
       "translation": [10, 20, 3], "rotation_z_deg": 90, "scale": [1, 4, 6]},
      {"shape": "sphere", "class": "dynamic", "scale": 2},
      {"shape": "plane", "class": "terrain"}]})");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->instances.size(), 3u);
  const Instance& wall = w->instances[0];
  EXPECT_EQ(wall.name, "wall");
  EXPECT_EQ(wall.cls, InstanceClass::kStatic);
  EXPECT_NEAR(w->meshes[wall.mesh].albedo.r, 0.8, kFloatTolerance);
  EXPECT_EQ(w->meshes[wall.mesh].triangleCount(), 12u);
  // Unit box scaled to 1 x 4 x 6, turned 90 deg: the long side now runs along x.
  const glm::dvec3 corner = glm::dvec3(wall.transform * glm::dvec4(0.5, 0.5, 0.5, 1.0));
  EXPECT_NEAR(corner.x, 10 - 2, 1e-9);
  EXPECT_NEAR(corner.y, 20 + 0.5, 1e-9);
  EXPECT_NEAR(corner.z, 3 + 3, 1e-9);
  EXPECT_EQ(w->instances[1].cls, InstanceClass::kDynamic);
  EXPECT_EQ(w->instances[1].name, "primitives[1]");
  EXPECT_EQ(w->instances[2].cls, InstanceClass::kTerrain);
  EXPECT_EQ(w->meshes[w->instances[2].mesh].triangleCount(), 2u);
}

TEST(WorldJson, ParsesLightsInteriorsEffectsAndSky) {
  const auto w = parse(R"({
    "name": "test",
    "lights": [{"name": "torch", "position": [1, 2, 3], "intensity": [4, 5, 6], "radius_m": 7}],
    "interiors": [{"name": "hut", "min": [0, 0, 0], "max": [4, 4, 3], "probe": [2, 2, 1.5], "blend_m": 0.5}],
    "effects": ["sun_bounce", "local_lights"],
    "sky": {"latitude_deg": 45, "declination_deg": -10, "north_deg": 30, "ground_radiance_scale": 0.25,
            "sun_irradiance": [[6, 1, 0.5, 0.25], [12, 3, 3, 3]],
            "sky_zenith": [[0, 0.1, 0.2, 0.3]],
            "sky_horizon": [[0, 0.3, 0.2, 0.1], [12, 0.6, 0.4, 0.2]]}})");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->name, "test");
  ASSERT_EQ(w->lights.size(), 1u);
  EXPECT_EQ(w->lights[0].name, "torch");
  EXPECT_EQ(w->lights[0].position, glm::dvec3(1, 2, 3));
  EXPECT_EQ(w->lights[0].intensity, glm::vec3(4, 5, 6));
  EXPECT_EQ(w->lights[0].radius_m, 7.f);
  ASSERT_EQ(w->interiors.size(), 1u);
  EXPECT_EQ(w->interiors[0].max, glm::dvec3(4, 4, 3));
  EXPECT_EQ(w->interiors[0].probe_position, glm::dvec3(2, 2, 1.5));
  EXPECT_EQ(w->interiors[0].blend_distance_m, 0.5f);
  EXPECT_TRUE(w->effects_explicit);
  EXPECT_EQ(w->effects, uint32_t(kEffectSunBounce | kEffectLocalLights));
  EXPECT_NEAR(w->sky.latitude_rad, 45 * M_PI / 180, 1e-12);
  EXPECT_NEAR(w->sky.declination_rad, -10 * M_PI / 180, 1e-12);
  EXPECT_NEAR(w->sky.north_rad, 30 * M_PI / 180, 1e-12);
  EXPECT_EQ(w->sky.ground_radiance_scale, 0.25f);
  EXPECT_NEAR(w->sky.sun_irradiance.at(9.0).x, 2.0, kFloatTolerance);
  EXPECT_NEAR(w->sky.sky_zenith.at(17.0).z, 0.3, kFloatTolerance);
  EXPECT_NEAR(w->sky.sky_horizon.at(18.0).x, 0.45, kFloatTolerance);  // wraps 12 h -> 0 h
}

// A light with a path moves: keys in time, linear between them, clamped (or wrapped with loop).
// The world keeps the light where its path starts, for the bake and the archive.
TEST(WorldJson, ParsesLightPathsAndPlaysThem) {
  const auto w = parse(R"({"lights": [
    {"name": "torch", "position": [0, 0, 2], "intensity": [4, 3, 2], "radius_m": 8,
     "path": {"keys": [{"t_s": 1, "position": [10, 0, 2]}, {"t_s": 3, "position": [10, 20, 2], "intensity": [0, 0, 0]}]}},
    {"name": "fire", "position": [5, 5, 1],
     "path": {"loop": true, "keys": [{"t_s": 0, "position": [5, 5, 1]}, {"t_s": 0.5, "position": [5, 5, 1], "intensity": [3, 3, 3]},
                                     {"t_s": 1, "position": [5, 5, 1]}]}},
    {"name": "still", "position": [1, 2, 3]}]})");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->lights.size(), 3u);
  ASSERT_EQ(w->light_paths.size(), 3u);
  EXPECT_EQ(w->lights[0].position, glm::dvec3(10, 0, 2)) << "kept where the path starts";
  EXPECT_TRUE(w->light_paths[2].keys.empty());
  const LightPath& torch = w->light_paths[0];
  EXPECT_EQ(lightAt(w->lights[0], torch, -5.0).position, glm::dvec3(10, 0, 2));
  const PointLight mid = lightAt(w->lights[0], torch, 2.0);
  EXPECT_EQ(mid.position, glm::dvec3(10, 10, 2));
  EXPECT_FLOAT_EQ(mid.intensity.r, 2.f);  // halfway from the light's 4 to 0
  EXPECT_FLOAT_EQ(mid.radius_m, 8.f);
  EXPECT_EQ(lightAt(w->lights[0], torch, 99.0).position, glm::dvec3(10, 20, 2));
  const LightPath& fire = w->light_paths[1];
  EXPECT_TRUE(fire.loop);
  EXPECT_FLOAT_EQ(lightAt(w->lights[1], fire, 0.25).intensity.g, 2.f);
  EXPECT_FLOAT_EQ(lightAt(w->lights[1], fire, 10.25).intensity.g, 2.f) << "wrapped by the 1 s period";
  EXPECT_FLOAT_EQ(lightAt(w->lights[1], fire, -0.75).intensity.g, 2.f);
}

TEST(WorldJson, RejectsBadLightsAndPathsNamingTheKey) {
  expectError(R"({"lights": [{"position": [0, 0, "x"]}]})", "key 'lights[0].position': expected array of 3 numbers");
  expectError(R"({"lights": [{"position": [0, 0, 1], "radius_m": 0}]})", "key 'lights[0].radius_m': 0 out of range");
  expectError(R"({"lights": [{"position": [0, 0, 1], "radius_m": -2}]})", "key 'lights[0].radius_m'");
  expectError(R"({"lights": [{"position": [0, 0, 1], "intensity": [1, -1, 1]}]})", "key 'lights[0].intensity[1]'");
  expectError(R"({"lights": [{"position": [2e7, 0, 1]}]})", "key 'lights[0].position[0]': 2e+07 out of range");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"keys": [{"t_s": 0, "position": [0, 0, 1]}]}}]})",
              "key 'lights[0].path.keys': a path needs at least 2 keys");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"keys": [{"t_s": 1, "position": [0, 0, 1]}, {"t_s": 1, "position": [1, 0, 1]}]}}]})",
              "key 'lights[0].path.keys[1].t_s': must be greater");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"keys": [{"t_s": 0, "position": [0, 0, 1]}, {"t_s": 1, "position": [1e8, 0, 1]}]}}]})",
              "key 'lights[0].path.keys[1].position[0]'");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"keys": [{"t_s": 0, "position": [0, 0, 1]}, {"t_s": 1, "position": [1, 0, 1], "radius_m": 0}]}}]})",
              "key 'lights[0].path.keys[1].radius_m'");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"loop": 1, "keys": []}}]})", "key 'lights[0].path.keys': a path needs");
  expectError(R"({"lights": [{"position": [0, 0, 1], "path": {"speed": 3}}]})", "key 'lights[0].path.speed': unknown key");
  // NaN cannot be written in JSON; a library caller's path is checked by validateLightPath.
  LightPath p{{{0.0, {0, 0, 1}}, {std::nan(""), {0, 0, 1}}}};
  ASSERT_FALSE(validateLightPath(p));
  EXPECT_NE(validateLightPath(p).error().message.find("keys[1].t_s: must be finite"), std::string::npos)
      << validateLightPath(p).error().message;
  p.keys[1].t_s = 1.0;
  p.keys[1].intensity = glm::vec3(NAN);
  ASSERT_FALSE(validateLightPath(p));
  EXPECT_NE(validateLightPath(p).error().message.find("keys[1].intensity"), std::string::npos);
  p.keys[1].intensity = glm::vec3(1.f);
  EXPECT_TRUE(validateLightPath(p));
}

TEST(WorldJson, DefaultEffectsFollowContentWhenAbsent) {
  const auto without = parse(R"({"primitives": [{"shape": "box"}]})");
  ASSERT_TRUE(without.has_value());
  EXPECT_FALSE(without->effects & kEffectLocalLights);
  const auto with = parse(R"({"lights": [{"position": [0, 0, 1]}]})");
  ASSERT_TRUE(with.has_value());
  EXPECT_TRUE(with->effects & kEffectLocalLights);
  EXPECT_FALSE(with->effects_explicit);
}

TEST(WorldJson, BuildsNoiseTerrainOfTheRequestedSize) {
  const auto w = parse(R"({"terrain": {"kind": "noise", "size_m": 64, "resolution_m": 2, "height_m": 5, "seed": 9,
                                        "albedo": [0.2, 0.6, 0.15], "translation": [1000, 0, 0]}})");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->instances.size(), 1u);
  EXPECT_EQ(w->instances[0].cls, InstanceClass::kTerrain);
  EXPECT_EQ(w->triangleCount(), 2u * 32 * 32);
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.min.x, 1000 - 32, 1e-3);
  EXPECT_NEAR(b.max.y, 32, 1e-3);
  EXPECT_GE(b.min.z, 0.0);
  EXPECT_LE(b.max.z, 5.0);
  EXPECT_GT(b.max.z - b.min.z, 0.5);  // not flat
}

TEST(WorldJson, BuildsHeightmapTerrainFromSixteenBitPng) {
  const std::string png = DRTV_TEST_ASSETS "/terrain_vulkan_samples/terrain_heightmap_r16.DERIVED.png";
  const auto coarse = parse(R"({"terrain": {"kind": "heightmap", "path": ")" + png +
                            R"(", "size_m": 1000, "height_m": 100, "resolution_m": 8}})");
  ASSERT_TRUE(coarse.has_value()) << coarse.error().message;
  EXPECT_EQ(coarse->triangleCount(), 2u * 125 * 125);
  const Bounds b = coarse->bounds();
  EXPECT_NEAR(b.min.x, -500, 1e-3);
  EXPECT_NEAR(b.max.x, 500, 1e-3);
  EXPECT_GE(b.min.z, 0.0);
  EXPECT_LE(b.max.z, 100.0);
  EXPECT_GT(b.max.z - b.min.z, 10.0);  // a real heightmap, not a decode failure
  // One vertex per texel by default: 1024 x 1024 texels.
  const auto full = parse(R"({"terrain": {"kind": "heightmap", "path": ")" + png + R"(", "size_m": 1000, "height_m": 100}})");
  ASSERT_TRUE(full.has_value()) << full.error().message;
  EXPECT_EQ(full->triangleCount(), 2u * 1023 * 1023);
  // The coarse grid samples the same surface: its extreme heights lie within the full one's.
  const Bounds fb = full->bounds();
  EXPECT_GE(b.min.z, fb.min.z - 1e-3);
  EXPECT_LE(b.max.z, fb.max.z + 1e-3);
}

TEST(WorldJson, ResolvesGltfPathsRelativeToTheFile) {
  // The base dir is the test assets folder; the path inside is relative to it.
  const auto w = parseWorldJson(R"({"gltf": [{"path": "draco_box/Box_Draco.glb", "class": "vegetation",
                                             "translation": [0, 0, 10], "rotation_z_deg": 0, "scale": 2}]})",
                                DRTV_TEST_ASSETS, "assets/x.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 12u);
  EXPECT_EQ(w->instances[0].cls, InstanceClass::kVegetation);
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.min.z, 10 - 1, 1e-5);  // a 1 m box scaled by 2 around z = 10
  EXPECT_NEAR(b.max.z, 10 + 1, 1e-5);
}

TEST(WorldJson, ScattersVegetationOnTheTerrainDeterministically) {
  const std::string text = R"({
    "terrain": {"kind": "noise", "size_m": 100, "resolution_m": 2, "height_m": 10, "seed": 2},
    "vegetation": [{"name": "bush", "count": 50, "seed": 4, "scale": [0.5, 1.5],
                    "region": {"min": [-40, -40], "max": [40, 40]},
                    "mesh": {"primitive": "sphere", "albedo": [0.1, 0.4, 0.1], "size": [2, 2, 3]}}]})";
  const auto a = parse(text), b = parse(text);
  ASSERT_TRUE(a.has_value()) << a.error().message;
  ASSERT_EQ(a->instances.size(), 51u);
  for (size_t i = 1; i < a->instances.size(); ++i) {
    const Instance& inst = a->instances[i];
    EXPECT_EQ(inst.cls, InstanceClass::kVegetation);
    EXPECT_EQ(inst.transform, b->instances[i].transform);
    const glm::dvec3 p(inst.transform[3]);
    EXPECT_GE(p.x, -40);
    EXPECT_LE(p.x, 40);
    EXPECT_GE(p.z, 0.0);  // on the terrain, whose heights lie in [0, 10]
    EXPECT_LE(p.z, 10.0);
  }
  EXPECT_EQ(a->meshes[a->instances[1].mesh].albedo, glm::vec3(0.1f, 0.4f, 0.1f));
  EXPECT_TRUE(a->effects & kEffectVolumeBlur);
  // A glTF mesh scattered over a region without terrain stands on z = 0.
  const auto g = parseWorldJson(R"({"vegetation": [{"count": 3, "region": {"min": [0, 0], "max": [10, 10]},
                                                    "mesh": {"gltf": "outdoor_bevy_palmtree/PalmTree.gltf"}}]})",
                                DRTV_TEST_ASSETS, "assets/x.json");
  ASSERT_TRUE(g.has_value()) << g.error().message;
  EXPECT_GT(g->triangleCount(), 0u);
  EXPECT_EQ(g->instancesByClass()[size_t(InstanceClass::kVegetation)], g->instances.size());
}

TEST(WorldJson, IslandKeyGeneratesTheIsland) {
  const auto w = parse(R"({"island": {"size_km2": 0.25, "seed": 3, "trees_per_km2": 400}, "effects": ["sun_bounce"]})");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->name, "x");
  EXPECT_GT(w->instancesByClass()[size_t(InstanceClass::kVegetation)], 0u);
  EXPECT_EQ(w->effects, uint32_t(kEffectSunBounce));
}

TEST(WorldJson, RejectsDuplicateKeysNamingTheKeyPath) {
  expectError(R"({"name": "a", "name": "b"})", "key 'name': duplicate key");
  expectError(R"({"sky": {"latitude_deg": 10, "north_deg": 0, "latitude_deg": 20}})", "key 'sky.latitude_deg': duplicate key");
  expectError(R"({"primitives": [{"shape": "box"}, {"shape": "box", "albedo": [1, 1, 1], "albedo": [0, 0, 0]}]})",
              "key 'primitives[1].albedo': duplicate key");
  // The same key in different objects is not a duplicate.
  const auto ok = parse(R"({"primitives": [{"shape": "box", "name": "a"}, {"shape": "box", "name": "b"}]})");
  EXPECT_TRUE(ok.has_value()) << ok.error().message;
}

// Writes an 8-bit RGB PNG whose texel (x, y) is colour(x, y); returns its path.
template <class F>
std::string writeTestPng(const std::string& stem, int w, int h, F colour) {
  drtv::image::RgbImage img;
  img.width = w;
  img.height = h;
  img.pixels.resize(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const glm::ivec3 c = colour(x, y);
      img.set(x, y, uint8_t(c.r), uint8_t(c.g), uint8_t(c.b));
    }
  const std::string path = ::testing::TempDir() + "drtv_json_test_" + stem + "_" + std::to_string(::getpid()) + ".png";
  EXPECT_TRUE(drtv::image::writePng(path, img).has_value());
  return path;
}

std::string heightmapWorld(const std::string& png) {
  return R"({"terrain": {"kind": "heightmap", "path": ")" + png + R"(", "size_m": 100, "height_m": 10}})";
}

TEST(WorldJson, RejectsANonSquareHeightmapNamingFileAndKey) {
  const std::string png = writeTestPng("wide", 30, 20, [](int x, int) { return glm::ivec3(x * 8); });
  expectError(heightmapWorld(png), "key 'terrain.path': " + png + ": heightmap is 30x20 texels: it must be square");
}

TEST(WorldJson, RejectsAColouredHeightmapNamingTheTexel) {
  const std::string png = writeTestPng("coloured", 16, 16, [](int x, int y) {
    return x == 5 && y == 7 ? glm::ivec3(200, 10, 10) : glm::ivec3(x * 16);
  });
  expectError(heightmapWorld(png), "key 'terrain.path': " + png + ": heightmap texel (5, 7) is coloured");
}

TEST(WorldJson, TakesAGreyRgbHeightmapAsGrayscaleCentredAndSquare) {
  const std::string png = writeTestPng("grey", 16, 16, [](int x, int) { return glm::ivec3(x * 17); });  // 0 .. 255
  const auto w = parse(heightmapWorld(png));
  ASSERT_TRUE(w.has_value()) << w.error().message;
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.min.x, -50, 1e-3);
  EXPECT_NEAR(b.max.x, 50, 1e-3);
  EXPECT_NEAR(b.min.y, -50, 1e-3);
  EXPECT_NEAR(b.max.y, 50, 1e-3);
  EXPECT_NEAR(b.min.z, 0.0, 1e-3);   // black
  EXPECT_NEAR(b.max.z, 10.0, 1e-3);  // white = height_m
}

TEST(LoadWorld, LoadsTheTestBox) {
  const auto w = loadWorld(DRTV_SOURCE_DIR "/worlds/fc3_testbox.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->name, "fc3_testbox");
  const auto by_class = w->instancesByClass();
  EXPECT_EQ(by_class[size_t(InstanceClass::kTerrain)], 1u);
  EXPECT_EQ(by_class[size_t(InstanceClass::kStatic)], 2u);
  EXPECT_GE(by_class[size_t(InstanceClass::kDynamic)], 3u);
  // A red wall at -x and a blue wall at +x.
  glm::vec3 west_albedo(0.f), east_albedo(0.f);
  for (const Instance& inst : w->instances) {
    if (inst.cls != InstanceClass::kStatic) continue;
    (inst.transform[3].x < 0 ? west_albedo : east_albedo) = w->meshes[inst.mesh].albedo;
  }
  EXPECT_GT(west_albedo.r, 0.5f);
  EXPECT_GT(east_albedo.b, 0.5f);
  // The morning sun comes from +x (east), so it lights the red wall's east face.
  EXPECT_GT(w->sky.sunDirection(9.0).x, 0.0);
  // A few 64 m sectors at most.
  EXPECT_LE(summarize(*w).sectors, 4u);
  EXPECT_FALSE(w->effects & kEffectLocalLights);
}

TEST(LoadWorld, LoadsTheDemoIsland) {
  const auto w = loadWorld(DRTV_SOURCE_DIR "/worlds/island.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  const Bounds b = w->bounds();
  EXPECT_NEAR(b.max.x - b.min.x, 1000.0, 1.0);
  EXPECT_NEAR(b.max.y - b.min.y, 1000.0, 1.0);
  EXPECT_GT(w->interiors.size(), 0u);
}

TEST(LoadWorld, LoadsGltfAsOneStaticWorld) {
  const auto w = loadWorld(DRTV_TEST_ASSETS "/cornell_bevy/CornellBox.glb");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_GT(w->triangleCount(), 0u);
  EXPECT_EQ(w->instancesByClass()[size_t(InstanceClass::kStatic)], w->instances.size());
}

TEST(LoadWorld, RejectsUnknownExtensionsAndMissingFilesNamingThem) {
  const auto a = loadWorld("worlds/x.obj");
  ASSERT_FALSE(a.has_value());
  EXPECT_EQ(a.error().message.rfind("worlds/x.obj: ", 0), 0u);
  const auto b = loadWorld("worlds/missing.json");
  ASSERT_FALSE(b.has_value());
  EXPECT_EQ(b.error().message.rfind("worlds/missing.json: ", 0), 0u);
}

}  // namespace
}  // namespace drtv::worlds
