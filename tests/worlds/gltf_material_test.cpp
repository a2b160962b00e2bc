// Tests of what the glTF loader does with materials (docs/world-format.md, "Materials"):
// emission becomes point lights carrying the emitter's flux, metals lose their diffuse lobe,
// MASK and BLEND keep or drop whole primitives, and every class is counted and noted.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>

#include "base64.h"
#include "drtv/worlds/gltf.h"
#include "drtv/worlds/load.h"
#include "drtv/worlds/summary.h"

namespace drtv::worlds {
namespace {

// Float sums of a few light intensities (each Le A / 2 in double, stored as float).
constexpr double kIntensityRelTolerance = 1e-5;

using test_data::base64;

// A glTF file with one mesh of one primitive per material: each primitive is the quad
// x in [-w/2, w/2], z in [-d/2, d/2] at glTF height y (drtv: z = y), its front face towards -y
// (drtv: down). `materials` are glTF material objects, as JSON text. `node_extra` adds to the
// node (a "scale").
std::filesystem::path writeQuads(const std::string& name, const std::vector<std::string>& materials, float w, float d,
                                 float y, const std::string& node_extra = "") {
  const glm::vec3 corners[4] = {{-w / 2, y, -d / 2}, {w / 2, y, -d / 2}, {w / 2, y, d / 2}, {-w / 2, y, d / 2}};
  // (0, 1, 2): (b - a) x (c - a) = (w, 0, 0) x (w, 0, d) = (0, -w d, 0): faces -y.
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::vector<unsigned char> bytes(sizeof corners + sizeof idx);
  std::memcpy(bytes.data(), corners, sizeof corners);
  std::memcpy(bytes.data() + sizeof corners, idx, sizeof idx);
  std::ostringstream s;
  s << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0)" << node_extra
    << R"(}], "meshes": [{"name": "quads", "primitives": [)";
  for (size_t m = 0; m < materials.size(); ++m)
    s << (m ? ", " : "") << R"({"attributes": {"POSITION": 0}, "indices": 1, "material": )" << m << "}";
  s << R"(]}], "materials": [)";
  for (size_t m = 0; m < materials.size(); ++m) s << (m ? ", " : "") << materials[m];
  s << R"(], "buffers": [{"byteLength": )" << bytes.size() << R"(, "uri": "data:application/octet-stream;base64,)"
    << base64(bytes) << R"("}], "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},)"
    << R"({"buffer": 0, "byteOffset": 48, "byteLength": 12}], "accessors": [)"
    << R"({"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-10, -10, -10], "max": [10, 10, 10]},)"
    << R"({"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]})";
  const auto path = std::filesystem::temp_directory_path() / ("drtv_material_test_" + name + ".gltf");
  std::ofstream(path) << s.str();
  return path;
}

bool hasNote(const World& w, const std::string& what) {
  for (const std::string& n : w.notes)
    if (n.find(what) != std::string::npos) return true;
  return false;
}

glm::dvec3 totalIntensity(const World& w) {
  glm::dvec3 sum(0.0);
  for (const PointLight& l : w.lights) sum += glm::dvec3(l.intensity);
  return sum;
}

void expectRelNear(double got, double want, double rel) { EXPECT_NEAR(got, want, rel * std::abs(want)) << got << " vs " << want; }

TEST(GltfMaterials, AnEmissiveQuadBecomesPointLightsCarryingItsFlux) {
  // Le = (1, 0.5, 0.25) x strength 10; a 1.6 m x 1 m quad at height 3 m facing down.
  const auto path = writeQuads("emissive",
                               {R"({"name": "lamp", "emissiveFactor": [1, 0.5, 0.25],
                                    "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}},
                                    "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}})"},
                               1.6f, 1.f, 3.f);
  const auto w = loadGltf(path);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  const double area = 1.6;
  // I = Le A / 2: the flux 2 pi I of the lights' front half is the emitter's pi Le A.
  const glm::dvec3 want = 0.5 * glm::dvec3(10.0, 5.0, 2.5) * area;
  const glm::dvec3 got = totalIntensity(*w);
  for (int c = 0; c < 3; ++c) expectRelNear(got[c], want[c], kIntensityRelTolerance);
  // 1.6 m^2 is above kEmitterPatchAreaM2: cut once along its long side into two flat halves.
  ASSERT_EQ(w->lights.size(), 2u);
  for (const PointLight& l : w->lights) {
    EXPECT_NEAR(l.position.z, 3.0 - kEmitterLightOffsetM, 1e-6) << "in front of (below) the emitter";
    EXPECT_NEAR(std::abs(l.position.x), 0.4, 1e-6) << "at the centre of its half";
    EXPECT_NEAR(l.position.y, 0.0, 1e-6);
  }
  EXPECT_EQ(w->meshes.at(0).albedo, glm::vec3(0.f)) << "an emitter reflects nothing (its lights' back half lands on it)";
  EXPECT_EQ(w->materials.emissive, 1u);
  EXPECT_EQ(w->materials.emissive_lights, 2u);
  EXPECT_TRUE(w->effects & kEffectLocalLights) << "the lights ask for LPRT";
  EXPECT_TRUE(hasNote(*w, "emissive: ")) << "the conversion is said";
  EXPECT_TRUE(hasNote(*w, "material 'lamp': emissive"));
}

TEST(GltfMaterials, EmittersAreMeasuredInWorldSpace) {
  // The node scales by 2: four times the area, four times the intensity.
  const auto path = writeQuads("emissive_scaled", {R"({"emissiveFactor": [1, 1, 1]})"}, 0.5f, 0.5f, 1.f,
                               R"(, "scale": [2, 2, 2])");
  const auto w = loadGltf(path);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->lights.size(), 1u) << "1 m^2 and flat: one light";
  expectRelNear(totalIntensity(*w).g, 0.5 * 1.0, kIntensityRelTolerance);
  EXPECT_NEAR(w->lights[0].position.z, 2.0 - kEmitterLightOffsetM, 1e-6);
}

TEST(GltfMaterials, AMaterialWithoutEmissionMakesNoLight) {
  const auto path = writeQuads("plain", {R"({"pbrMetallicRoughness": {"metallicFactor": 0}})"}, 1.f, 1.f, 1.f);
  const auto w = loadGltf(path);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_TRUE(w->lights.empty());
  EXPECT_FALSE(w->effects & kEffectLocalLights);
  EXPECT_EQ(w->materials.opaque, 1u);
  EXPECT_EQ(w->meshes.at(0).albedo, glm::vec3(1.f));
}

TEST(GltfMaterials, AMetalHasNoDiffuseLobe) {
  const auto path = writeQuads("metal",
                               {R"({"name": "brass", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.4, 1], "metallicFactor": 0.75}})",
                                R"({"name": "default metal", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.4, 1]}})"},
                               1.f, 1.f, 1.f);
  const auto w = loadGltf(path);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->meshes.size(), 2u);
  const glm::vec3 a = w->meshes[0].albedo;
  EXPECT_NEAR(a.r, 0.2f, 1e-6f);
  EXPECT_NEAR(a.g, 0.15f, 1e-6f);
  EXPECT_NEAR(a.b, 0.1f, 1e-6f);
  // glTF's metallicFactor defaults to 1 [spec 3.9.2]: a material that names none is a metal.
  EXPECT_EQ(w->meshes[1].albedo, glm::vec3(0.f));
  EXPECT_EQ(w->materials.metallic, 2u);
  EXPECT_TRUE(hasNote(*w, "material 'brass': metallic 0.75: diffuse albedo = base colour x 0.25"));
}

TEST(GltfMaterials, MaskAndBlendKeepOrDropWholePrimitives) {
  const auto path = writeQuads("alpha",
                               {R"({"name": "cut", "alphaMode": "MASK", "alphaCutoff": 0.5,
                                    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.3], "metallicFactor": 0}})",
                                R"({"name": "solid mask", "alphaMode": "MASK", "alphaCutoff": 0.5,
                                    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.9], "metallicFactor": 0}})",
                                R"({"name": "glass", "alphaMode": "BLEND",
                                    "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.4], "metallicFactor": 0}})",
                                R"({"name": "smoked", "alphaMode": "BLEND",
                                    "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 0.6], "metallicFactor": 0}})"},
                               1.f, 1.f, 1.f);
  GltfStats stats;
  const auto w = loadGltf(path, InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->meshes.size(), 2u) << "the MASK under its cutoff and the mostly transparent BLEND are left out";
  EXPECT_NE(w->meshes[0].name.find("primitive 1"), std::string::npos) << w->meshes[0].name;
  EXPECT_NE(w->meshes[1].name.find("primitive 3"), std::string::npos) << w->meshes[1].name;
  EXPECT_EQ(w->meshes[1].albedo, glm::vec3(0.5f)) << "kept opaque, its colour not scaled by alpha";
  EXPECT_EQ(stats.primitives_skipped, 2u);
  EXPECT_EQ(w->materials.mask_skipped, 1u);
  EXPECT_EQ(w->materials.mask_kept, 1u);
  EXPECT_EQ(w->materials.blend_skipped, 1u);
  EXPECT_EQ(w->materials.blend_kept, 1u);
  EXPECT_TRUE(hasNote(*w, "skipped: ")) << "each left-out primitive is noted";
  EXPECT_TRUE(hasNote(*w, "alphaMode MASK, baseColorFactor alpha 0.3 < alphaCutoff 0.5"));
  EXPECT_TRUE(hasNote(*w, "alphaMode BLEND, mean alpha 0.4 < 0.5"));
  EXPECT_TRUE(hasNote(*w, "material 'smoked': alphaMode BLEND, mean alpha 0.6 >= 0.5: opaque"));
}

TEST(GltfMaterials, DoubleSidedMaterialsAreCountedAndSaid) {
  const auto path = writeQuads("double", {R"({"doubleSided": true, "pbrMetallicRoughness": {"metallicFactor": 0}})"}, 1.f, 1.f, 1.f);
  const auto w = loadGltf(path);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_TRUE(w->meshes.at(0).double_sided);
  EXPECT_EQ(w->materials.double_sided, 1u);
  EXPECT_TRUE(hasNote(*w, "materials double-sided: a surface from both sides"));
}

TEST(GltfMaterials, TheCornellBoxQuadIsItsOnlyLight) {
  const auto w = loadGltf(DRTV_TEST_ASSETS "/cornell_bevy/CornellBox.glb");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  // Emitter_Light_temp: emissiveFactor 1 x emissiveStrength 100 on a 130 x 105 quad facing down.
  const double le = 100.0, area = 130.0 * 105.0;
  ASSERT_FALSE(w->lights.empty());
  EXPECT_LE(w->lights.size(), kMaxLightsPerEmitter);
  const glm::dvec3 got = totalIntensity(*w);
  for (int c = 0; c < 3; ++c) expectRelNear(got[c], 0.5 * le * area, 1e-4);  // float corners, ~1e-6 m
  for (const PointLight& l : w->lights) EXPECT_NEAR(l.position.z, 547.9134521484375 - kEmitterLightOffsetM, 1e-3);
  EXPECT_EQ(w->materials.emissive, 1u);
  EXPECT_EQ(w->materials.double_sided, 5u);
  EXPECT_EQ(w->materials.materials, 5u);
}

TEST(GltfMaterials, AWorldFilePlacesTheEmittersItImports) {
  // cornell_world.json scales the box by 0.02: 0.0004 of the area; its own lamp stays lights[0].
  const auto w = loadWorld(DRTV_SOURCE_DIR "/tests/reference/data/cornell_world.json");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_GE(w->lights.size(), 2u);
  EXPECT_EQ(w->lights[0].name, "lamp");
  EXPECT_EQ(w->light_paths.size(), w->lights.size()) << "one (empty) path per light, as the world file's";
  glm::dvec3 emitted(0.0);
  for (size_t i = 1; i < w->lights.size(); ++i) emitted += glm::dvec3(w->lights[i].intensity);
  expectRelNear(emitted.g, 0.5 * 100.0 * 130.0 * 105.0 * 0.02 * 0.02, 1e-4);
  EXPECT_EQ(w->materials.emissive, 1u);
  EXPECT_EQ(w->materials.emissive_lights, w->lights.size() - 1);
  const std::string info = toString(summarize(*w));
  EXPECT_NE(info.find("emissive 1"), std::string::npos) << info;
}

// A flat 4 m x 4 m emitter facing down: 16 patches of 1 m^2, one light each.
Mesh emitter() {
  Mesh m;
  m.name = "panel";
  m.positions = {{-2, -2, 3}, {2, -2, 3}, {2, 2, 3}, {-2, 2, 3}};
  m.indices = {0, 2, 1, 0, 3, 2};
  m.albedo = glm::vec3(0.f);
  m.emission = glm::vec3(1.f);
  return m;
}

TEST(EmissiveLights, StopAtTheirCapAndSkipDynamicEmittersSayingSo) {
  World w;
  w.meshes = {emitter()};
  const size_t placed = kMaxEmissiveLights / kMaxLightsPerEmitter + 2;  // two more than fit
  for (size_t i = 0; i < placed; ++i)
    w.instances.push_back({0, glm::dmat4(1.0), InstanceClass::kStatic, "panel " + std::to_string(i)});
  w.instances.push_back({0, glm::dmat4(1.0), InstanceClass::kDynamic, "carried panel"});
  w.instances[0].name = std::string(100000, 'x');  // a file's node name may be any length
  emissiveLights(w);
  EXPECT_EQ(w.lights.size(), kMaxEmissiveLights);
  EXPECT_EQ(w.materials.emissive_lights, kMaxEmissiveLights);
  EXPECT_EQ(w.materials.emissive_instances_not_converted, 3u) << "two past the cap, one dynamic";
  EXPECT_TRUE(w.light_paths.empty()) << "no paths where the world had none";
  ASSERT_EQ(w.notes.size(), 1u);
  EXPECT_NE(w.notes[0].find("2 instances not converted"), std::string::npos) << w.notes[0];
  EXPECT_NE(w.notes[0].find("1 dynamic instances not converted"), std::string::npos) << w.notes[0];
  for (const PointLight& l : w.lights) EXPECT_LT(l.name.size(), 1000u) << "the archive stores 16-bit name lengths";
  glm::dvec3 sum = totalIntensity(w);
  expectRelNear(sum.g, 0.5 * 16.0 * double(kMaxEmissiveLights / kMaxLightsPerEmitter), kIntensityRelTolerance);
}

TEST(EmissiveLights, AMirroringTransformKeepsTheEmittingSide) {
  // Mirrored in x: the winding turns clockwise, the ray tracer swaps two corners
  // (world_geometry.cpp) and the front still faces down; the lights stay below the panel.
  World w;
  w.meshes = {emitter()};
  w.instances.push_back({0, glm::dmat4(glm::dvec4(-1, 0, 0, 0), glm::dvec4(0, 1, 0, 0), glm::dvec4(0, 0, 1, 0), glm::dvec4(0, 0, 0, 1)),
                         InstanceClass::kStatic, "mirrored"});
  emissiveLights(w);
  ASSERT_EQ(w.lights.size(), 16u);
  for (const PointLight& l : w.lights) EXPECT_NEAR(l.position.z, 3.0 - kEmitterLightOffsetM, 1e-6);
}

}  // namespace
}  // namespace drtv::worlds
