// Tests of glTF loading: axis conversion, topologies, Draco, the test assets (tests/assets) and every file
// of assimp's glTF 2.0 test set (valid and deliberately broken).
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "base64.h"
#include "drtv/worlds/gltf.h"
#include "drtv/worlds/load.h"

namespace drtv::worlds {
namespace {

// Positions go through one float multiply-add chain (C M C^-1): exact for these small values
// up to float rounding.
constexpr double kPositionTolerance = 1e-6;

using test_data::base64;

// Writes a one-primitive glTF with embedded buffer: positions (float3, byte stride 16 to
// exercise byteStride) and optional u16 indices; returns its path.
std::filesystem::path writeGltf(const std::string& name, int mode, const std::vector<glm::vec3>& positions,
                                const std::vector<uint16_t>& indices, const std::string& node_extra = "") {
  std::vector<unsigned char> bytes(positions.size() * 16, 0);
  for (size_t i = 0; i < positions.size(); ++i) std::memcpy(&bytes[i * 16], &positions[i], 12);
  const size_t pos_bytes = bytes.size();
  for (uint16_t idx : indices) {
    bytes.push_back(uint8_t(idx & 0xff));
    bytes.push_back(uint8_t(idx >> 8));
  }
  std::ostringstream s;
  s << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],)"
    << R"("nodes": [{"mesh": 0)" << node_extra << "}],"
    << R"("meshes": [{"name": "m", "primitives": [{"attributes": {"POSITION": 0}, "mode": )" << mode
    << (indices.empty() ? "" : R"(, "indices": 1)") << "}]}],"
    << R"("buffers": [{"byteLength": )" << bytes.size() << R"(, "uri": "data:application/octet-stream;base64,)"
    << base64(bytes) << R"("}],)"
    << R"("bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": )" << pos_bytes << R"(, "byteStride": 16})"
    << (indices.empty() ? "" : R"(, {"buffer": 0, "byteOffset": )" + std::to_string(pos_bytes) +
                                    R"(, "byteLength": )" + std::to_string(indices.size() * 2) + "}")
    << "],"
    << R"("accessors": [{"bufferView": 0, "componentType": 5126, "count": )" << positions.size()
    << R"(, "type": "VEC3", "min": [-10, -10, -10], "max": [10, 10, 10]})"
    << (indices.empty() ? "" : R"(, {"bufferView": 1, "componentType": 5123, "count": )" + std::to_string(indices.size()) +
                                    R"(, "type": "SCALAR"})")
    << "]}";
  const auto path = std::filesystem::temp_directory_path() / ("drtv_worlds_test_" + name + ".gltf");
  std::ofstream(path) << s.str();
  return path;
}

// World-space corners of triangle t of the first instance.
std::array<glm::dvec3, 3> worldTriangle(const World& w, size_t t) {
  const Instance& inst = w.instances.at(0);
  const Mesh& m = w.meshes.at(inst.mesh);
  std::array<glm::dvec3, 3> out;
  for (int k = 0; k < 3; ++k)
    out[size_t(k)] = glm::dvec3(inst.transform * glm::dvec4(glm::dvec3(m.positions.at(m.indices.at(3 * t + size_t(k)))), 1.0));
  return out;
}

void expectNear(const glm::dvec3& a, const glm::dvec3& b) {
  EXPECT_NEAR(a.x, b.x, kPositionTolerance);
  EXPECT_NEAR(a.y, b.y, kPositionTolerance);
  EXPECT_NEAR(a.z, b.z, kPositionTolerance);
}

TEST(Gltf, ConvertsYupToZup) {
  // glTF (x, y, z) -> drtv (x, -z, y).
  const auto path = writeGltf("yup", 4, {{1, 2, 3}, {4, 5, 6}, {0, 1, -1}}, {});
  GltfStats stats;
  const auto w = loadGltf(path, InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->triangleCount(), 1u);
  const auto tri = worldTriangle(*w, 0);
  expectNear(tri[0], {1, -3, 2});
  expectNear(tri[1], {4, -6, 5});
  expectNear(tri[2], {0, 1, 1});
  EXPECT_EQ(stats.primitives_loaded, 1u);
  // The glTF up axis (+Y) is drtv's +Z: a node moved 5 m up in glTF is 5 m up in drtv.
  const auto moved = loadGltf(writeGltf("yup_node", 4, {{1, 2, 3}, {4, 5, 6}, {0, 1, -1}}, {}, R"(, "translation": [0, 5, 0])"));
  ASSERT_TRUE(moved.has_value());
  expectNear(worldTriangle(*moved, 0)[0], {1, -3, 7});
  // A +90 deg rotation about glTF's Y (up) is +90 deg about drtv's Z: x -> y.
  const auto turned = loadGltf(writeGltf("yup_rot", 4, {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {},
                                         R"(, "rotation": [0, 0.7071067811865476, 0, 0.7071067811865476])"));
  ASSERT_TRUE(turned.has_value());
  expectNear(worldTriangle(*turned, 0)[0], {0, 1, 0});
}

TEST(Gltf, StripAndFanBecomeListsAsTheSpecSays) {
  // glTF 2.0 spec 3.7.2.1 written out for 5 vertices.
  EXPECT_EQ(gltfStripToList({0, 1, 2, 3, 4}), (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 2, 3, 4}));
  EXPECT_EQ(gltfFanToList({0, 1, 2, 3, 4}), (std::vector<uint32_t>{1, 2, 0, 2, 3, 0, 3, 4, 0}));
  EXPECT_TRUE(gltfStripToList({0, 1}).empty());
  EXPECT_TRUE(gltfFanToList({}).empty());
}

TEST(Gltf, LoadsStripsAndFansWithTheirTriangles) {
  const std::vector<glm::vec3> pts = {{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {1, 0, 1}, {2, 0, 0}};  // glTF y = 0 plane
  const auto strip = loadGltf(writeGltf("strip", 5, pts, {0, 1, 2, 3, 4}));
  ASSERT_TRUE(strip.has_value()) << strip.error().message;
  ASSERT_EQ(strip->triangleCount(), 3u);
  auto conv = [&](int i) { return glm::dvec3(pts[size_t(i)].x, -pts[size_t(i)].z, pts[size_t(i)].y); };
  const int strip_ref[3][3] = {{0, 1, 2}, {1, 3, 2}, {2, 3, 4}};
  for (size_t t = 0; t < 3; ++t) {
    const auto tri = worldTriangle(*strip, t);
    for (int k = 0; k < 3; ++k) expectNear(tri[size_t(k)], conv(strip_ref[t][k]));
  }
  const auto fan = loadGltf(writeGltf("fan", 6, pts, {}));  // non-indexed
  ASSERT_TRUE(fan.has_value()) << fan.error().message;
  ASSERT_EQ(fan->triangleCount(), 3u);
  const int fan_ref[3][3] = {{1, 2, 0}, {2, 3, 0}, {3, 4, 0}};
  for (size_t t = 0; t < 3; ++t) {
    const auto tri = worldTriangle(*fan, t);
    for (int k = 0; k < 3; ++k) expectNear(tri[size_t(k)], conv(fan_ref[t][k]));
  }
}

TEST(Gltf, SkipsLinesAndDropsDegenerateTrianglesWithNotes) {
  const auto lines = loadGltf(writeGltf("lines", 1, {{0, 0, 0}, {1, 0, 0}}, {}));
  ASSERT_TRUE(lines.has_value()) << lines.error().message;
  EXPECT_EQ(lines->triangleCount(), 0u);
  ASSERT_FALSE(lines->notes.empty());
  EXPECT_NE(lines->notes[0].find("skipped: "), std::string::npos);
  EXPECT_NE(lines->notes[0].find("lines"), std::string::npos);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  GltfStats stats;
  const auto bad = loadGltf(writeGltf("degenerate", 4, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {nan, 0, 0}},
                                      {0, 1, 2, 0, 1, 3, 0, 0, 2, 0, 1, 4}),
                            InstanceClass::kStatic, &stats);
  ASSERT_TRUE(bad.has_value()) << bad.error().message;
  EXPECT_EQ(bad->triangleCount(), 1u);
  EXPECT_EQ(stats.triangles_read, 4u);
  EXPECT_EQ(stats.dropped_degenerate, 2u);  // collinear (0,1,3) and repeated index (0,0,2)
  EXPECT_EQ(stats.dropped_nonfinite, 1u);
  for (const glm::vec3& p : bad->meshes[0].positions) EXPECT_TRUE(std::isfinite(p.x));  // unused NaN vertex removed
}

TEST(Gltf, SkipsPrimitivesWithIndicesOutOfRange) {
  GltfStats stats;
  const auto w = loadGltf(writeGltf("oob", 4, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {0, 1, 7}), InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value());
  EXPECT_EQ(w->triangleCount(), 0u);
  EXPECT_EQ(stats.primitives_skipped, 1u);
  ASSERT_FALSE(w->notes.empty());
  EXPECT_NE(w->notes[0].find("out of range"), std::string::npos);
}

TEST(Gltf, DracoBoxHasTwelveTriangles) {
  GltfStats stats;
  const auto w = loadGltf(DRTV_TEST_ASSETS "/draco_box/Box_Draco.glb", InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 12u);
  EXPECT_EQ(stats.dropped_degenerate + stats.dropped_nonfinite, 0u);
  // Its node matrix turns the Z-up box into glTF's Y-up; the result is the unit box again.
  const Bounds b = w->bounds();
  expectNear(b.min, glm::dvec3(-0.5));
  expectNear(b.max, glm::dvec3(0.5));
  EXPECT_NEAR(w->meshes[0].albedo.r, 0.8, 1e-6);  // baseColorFactor [0.8, 0, 0]
}

TEST(Gltf, DracoEngineHasItsTrueTriangleCount) {
  // 110,336 = sum over the nodes of the default scene (instanced) of indices.count / 3 of their
  // meshes' primitives, read from the accessors in draco/2CylinderEngine.gltf's JSON (a Python
  // walk of the node tree). Draco decoding must produce exactly that many triangles; the loader
  // then drops the zero-area ones, and kept + dropped must add up.
  constexpr size_t kDracoEngineTriangles = 110336;
  constexpr size_t kDracoEngineTrianglesPerMesh = 65311;  // the same accessors, each mesh once
  GltfStats stats;
  const auto w = loadGltf(DRTV_ASSIMP_GLTF2 "/draco/2CylinderEngine.gltf", InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(stats.primitives_skipped, 0u);
  EXPECT_EQ(stats.dropped_nonfinite, 0u);
  EXPECT_EQ(stats.triangles_read, kDracoEngineTrianglesPerMesh);
  EXPECT_EQ(stats.instanced_triangles_read, kDracoEngineTriangles);
  EXPECT_EQ(stats.instanced_triangles_kept, w->triangleCount());
  EXPECT_LT(stats.dropped_degenerate, 100u);  // a handful of zero-area triangles in the model
}

TEST(Gltf, DracoAndPlainEngineAgreeOnRealTriangles) {
  // The plain GLB of the same engine has 121,496 instanced triangles (the same Python walk over
  // its JSON chunk), 11,160 of them zero-area. The Draco encoder removed degenerate triangles,
  // so what the plain file keeps after dropping them is exactly what the Draco file holds.
  constexpr size_t kPlainEngineTriangles = 121496;
  constexpr size_t kDracoEngineTriangles = 110336;
  GltfStats draco, plain;
  const auto a = loadGltf(DRTV_ASSIMP_GLTF2 "/draco/2CylinderEngine.gltf", InstanceClass::kStatic, &draco);
  const auto b = loadGltf(DRTV_ASSIMP_GLTF2 "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", InstanceClass::kStatic, &plain);
  ASSERT_TRUE(a.has_value() && b.has_value());
  EXPECT_EQ(plain.instanced_triangles_read, kPlainEngineTriangles);
  EXPECT_EQ(b->triangleCount(), kDracoEngineTriangles);
  EXPECT_EQ(draco.instanced_triangles_read, kDracoEngineTriangles);
  // Draco's position quantisation collapses a few more tiny triangles to zero area.
  EXPECT_LE(a->triangleCount(), kDracoEngineTriangles);
  EXPECT_GT(a->triangleCount(), kDracoEngineTriangles - 100);
}

TEST(Gltf, LoadsTheSharedAssets) {
  for (const char* rel : {"/cornell_bevy/CornellBox.glb", "/outdoor_bevy_palmtree/PalmTree.gltf",
                          "/probe_room_bevy/IrradianceVolumeExample.glb", "/terrain_vulkan_samples/terrain.gltf"}) {
    const std::string path = std::string(DRTV_TEST_ASSETS) + rel;
    const auto w = loadGltf(path);
    ASSERT_TRUE(w.has_value()) << w.error().message;
    EXPECT_GT(w->triangleCount(), 0u) << path;
    EXPECT_FALSE(w->bounds().empty()) << path;
    for (const Mesh& m : w->meshes) {
      EXPECT_EQ(m.indices.size() % 3, 0u);
      for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size()) << m.name;
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(m.albedo[c], 0.f) << m.name;
        EXPECT_LE(m.albedo[c], 1.f) << m.name;
      }
    }
  }
}

TEST(Gltf, TexturedBoxAlbedoIsTheMeanLinearTextureColour) {
  // BoxTextured's base colour texture (CesiumLogoFlat.png) is mostly light grey/white with a
  // green logo; baseColorFactor is white. The mean linear colour is bright but not white.
  const auto w = loadGltf(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF/BoxTextured.gltf");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  ASSERT_EQ(w->meshes.size(), 1u);
  const glm::vec3 a = w->meshes[0].albedo;
  EXPECT_GT(a.g, 0.2f);
  EXPECT_LT(a.r + a.g + a.b, 3.f);
}

TEST(Gltf, RecursiveNodesAreSkippedNotFollowed) {
  const auto w = loadGltf(DRTV_ASSIMP_GLTF2 "/RecursiveNodes/RecursiveNodes.gltf");
  if (w.has_value()) {
    EXPECT_LT(w->instances.size(), 1000u);
  } else {
    EXPECT_NE(w.error().message.find("RecursiveNodes.gltf"), std::string::npos);
  }
}

TEST(Gltf, EveryAssimpTestFileLoadsOrFailsNamingTheFile) {
  size_t loaded = 0, failed = 0, files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(DRTV_ASSIMP_GLTF2)) {
    const auto ext = entry.path().extension().string();
    if (ext != ".gltf" && ext != ".glb") continue;
    ++files;
    const auto w = loadGltf(entry.path());
    if (w.has_value()) {
      ++loaded;
      for (const Mesh& m : w->meshes) {
        ASSERT_EQ(m.indices.size() % 3, 0u) << entry.path();
        for (uint32_t i : m.indices) ASSERT_LT(i, m.positions.size()) << entry.path();
        for (const glm::vec3& p : m.positions) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z)) << entry.path();
      }
    } else {
      ++failed;
      EXPECT_NE(w.error().message.find(entry.path().filename().string()), std::string::npos) << w.error().message;
    }
  }
  EXPECT_EQ(files, 46u);
  EXPECT_GE(loaded, 30u);  // most of the set is valid glTF
  std::printf("assimp glTF2 set: %zu files, %zu loaded, %zu rejected\n", files, loaded, failed);
}

TEST(Gltf, ValidAssimpModelsHaveTheirTriangles) {
  const auto box = loadGltf(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF-Binary/BoxTextured.glb");
  ASSERT_TRUE(box.has_value()) << box.error().message;
  EXPECT_EQ(box->triangleCount(), 12u);
  const auto infinites = loadGltf(DRTV_ASSIMP_GLTF2 "/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb");
  if (infinites.has_value()) {
    for (const Mesh& m : infinites->meshes)
      for (const glm::vec3& p : m.positions) EXPECT_TRUE(std::isfinite(p.x + p.y + p.z));
  }
}

TEST(Gltf, MissingFileIsAnErrorNamingIt) {
  const auto w = loadGltf("/nonexistent/thing.glb");
  ASSERT_FALSE(w.has_value());
  EXPECT_NE(w.error().message.find("/nonexistent/thing.glb"), std::string::npos);
}

}  // namespace
}  // namespace drtv::worlds
