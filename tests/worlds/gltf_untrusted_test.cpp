// Tests of glTF loading from untrusted bytes: loadGltfFromMemory, and KHR_draco_mesh_compression
// objects that point outside the file (tinygltf 2.7's own Draco path indexed them unchecked;
// worlds/src/draco_mesh.h), each built by editing the JSON chunk of the Draco box (tests/assets).
// Inputs the fuzzer (fuzz/fuzz_gltf.cpp, docs/fuzzing.md) found are kept here as regressions.
#include <cstring>
#include <initializer_list>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "base64.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/gltf.h"
#include "../../worlds/src/draco_mesh.h"  // the loader's Draco header reader, tested directly

namespace drtv::worlds {
namespace {

using json = nlohmann::json;

std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<uint8_t> dracoBox() { return readBytes(DRTV_TEST_ASSETS "/draco_box/Box_Draco.glb"); }

// The GLB `glb` with its JSON chunk replaced by edit(JSON).
std::vector<uint8_t> editGlbJson(const std::vector<uint8_t>& glb, const std::function<void(json&)>& edit) {
  uint32_t json_bytes;
  std::memcpy(&json_bytes, glb.data() + 12, 4);
  json doc = json::parse(glb.begin() + 20, glb.begin() + 20 + json_bytes);
  edit(doc);
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  const uint32_t chunk = uint32_t(text.size()), total = uint32_t(glb.size() - json_bytes + text.size());
  std::vector<uint8_t> out(total);
  std::memcpy(out.data(), glb.data(), 20);
  std::memcpy(out.data() + 8, &total, 4);
  std::memcpy(out.data() + 12, &chunk, 4);
  std::memcpy(out.data() + 20, text.data(), text.size());
  std::memcpy(out.data() + 20 + text.size(), glb.data() + 20 + json_bytes, glb.size() - 20 - json_bytes);
  return out;
}

json& dracoExtension(json& doc) { return doc["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]; }

// Loads `glb` from memory: it must load (bad primitives are skipped, not fatal), and the one
// primitive must be skipped with a note that names the file and contains `why`.
void expectDracoPrimitiveSkipped(const std::vector<uint8_t>& glb, const std::string& why) {
  GltfStats stats;
  const auto w = loadGltfFromMemory(glb, "edited.glb", "", InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 0u);
  EXPECT_EQ(stats.primitives_skipped, 1u);
  bool found = false;
  for (const std::string& note : w->notes)
    found |= note.rfind("skipped: edited.glb: mesh", 0) == 0 && note.find(why) != std::string::npos;
  EXPECT_TRUE(found) << "no note with '" << why << "'";
}

TEST(GltfFromMemory, LoadsTheDracoBoxLikeTheFile) {
  const auto from_file = loadGltf(DRTV_TEST_ASSETS "/draco_box/Box_Draco.glb");
  const auto from_memory = loadGltfFromMemory(dracoBox(), "box.glb", "");
  ASSERT_TRUE(from_file.has_value() && from_memory.has_value());
  EXPECT_EQ(from_memory->triangleCount(), 12u);
  EXPECT_EQ(from_memory->meshes.at(0).positions, from_file->meshes.at(0).positions);
  EXPECT_EQ(from_memory->meshes.at(0).indices, from_file->meshes.at(0).indices);
}

TEST(GltfFromMemory, TellsGlbFromJsonByTheMagic) {
  const std::string gltf = R"({"asset": {"version": "2.0"}, "nodes": [{}]})";
  const auto w = loadGltfFromMemory(std::vector<uint8_t>(gltf.begin(), gltf.end()), "x.gltf", "");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 0u);
  const auto bad = loadGltfFromMemory(std::vector<uint8_t>{'g', 'l', 'T', 'F', 2, 0, 0, 0}, "short.glb", "");
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message.rfind("short.glb: ", 0), 0u) << bad.error().message;
}

TEST(GltfDraco, SkipsAnExtensionWhoseBufferViewDoesNotExist) {
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { dracoExtension(d)["bufferView"] = 7; }),
                              "bufferView 7 does not exist");
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { dracoExtension(d)["bufferView"] = -1; }),
                              "bufferView -1 does not exist");
}

TEST(GltfDraco, SkipsABufferViewPastTheEndOfItsBuffer) {
  // tinygltf itself checks a view against its buffer only for views that accessors use; the
  // Draco view is used by no accessor.
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { d["bufferViews"][0]["byteOffset"] = 100; }),
                              "exceeds its buffer");
}

TEST(GltfDraco, SkipsAPositionIdThatTheBitstreamDoesNotHave) {
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { dracoExtension(d)["attributes"]["POSITION"] = 9; }),
                              "no Draco attribute with unique id 9");
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { dracoExtension(d)["attributes"].erase("POSITION"); }),
                              "no integer attributes.POSITION");
}

TEST(GltfDraco, SkipsABitstreamThatIsNotDraco) {
  std::vector<uint8_t> glb = dracoBox();
  // The BIN chunk's data starts after the JSON chunk and the 8-byte BIN chunk header.
  uint32_t json_bytes;
  std::memcpy(&json_bytes, glb.data() + 12, 4);
  for (size_t i = 20 + json_bytes + 8; i < glb.size(); ++i) glb[i] = 0xAB;
  expectDracoPrimitiveSkipped(glb, "not a Draco bitstream");
}

TEST(GltfDraco, SkipsATruncatedBitstream) {
  expectDracoPrimitiveSkipped(editGlbJson(dracoBox(), [](json& d) { d["bufferViews"][0]["byteLength"] = 40; }),
                              "Draco decoding failed");
}

// The Draco box with its bitstream replaced by `bitstream` (the BIN chunk, the buffer and the
// Draco bufferView resized to it).
std::vector<uint8_t> dracoBoxWithBitstream(std::vector<uint8_t> bitstream) {
  while (bitstream.size() % 4) bitstream.push_back(0);
  std::vector<uint8_t> glb = editGlbJson(dracoBox(), [&](json& d) {
    d["buffers"][0]["byteLength"] = bitstream.size();
    d["bufferViews"][0]["byteLength"] = bitstream.size();
  });
  uint32_t json_bytes;
  std::memcpy(&json_bytes, glb.data() + 12, 4);
  glb.resize(20 + json_bytes);
  const uint32_t bin_bytes = uint32_t(bitstream.size()), bin_type = 0x004E4942;  // "BIN\0"
  glb.insert(glb.end(), reinterpret_cast<const uint8_t*>(&bin_bytes), reinterpret_cast<const uint8_t*>(&bin_bytes) + 4);
  glb.insert(glb.end(), reinterpret_cast<const uint8_t*>(&bin_type), reinterpret_cast<const uint8_t*>(&bin_type) + 4);
  glb.insert(glb.end(), bitstream.begin(), bitstream.end());
  const uint32_t total = uint32_t(glb.size());
  std::memcpy(glb.data() + 8, &total, 4);
  return glb;
}

void appendVarint(std::vector<uint8_t>& out, uint64_t v) {
  do {
    out.push_back(uint8_t((v & 0x7f) | (v >= 0x80 ? 0x80 : 0)));
    v >>= 7;
  } while (v);
}

// A Draco 2.2 mesh header ("DRACO", version, mesh, `method`, no flags) followed by `counts` as
// varints and `tail` bytes of zeros: what the decoder reads before it allocates.
std::vector<uint8_t> dracoHeader(uint8_t method, std::initializer_list<uint64_t> counts, size_t tail) {
  std::vector<uint8_t> out = {'D', 'R', 'A', 'C', 'O', 2, 2, 1, method, 0, 0};
  if (method == 1) out.push_back(0);  // edgebreaker: the standard traversal
  size_t k = 0;
  for (uint64_t c : counts) {
    appendVarint(out, c);
    if (method == 1 && ++k == 2) out.push_back(0);  // edgebreaker: no attribute connectivity data
  }
  out.resize(out.size() + tail, 0);
  return out;
}

TEST(GltfDraco, ABitstreamDeclaringMoreThanTheMemoryLimitIsAnErrorNamingTheKey) {
  // A 40-byte bitstream may declare 4 billion points (sequential) or 700 million faces
  // (edgebreaker; Draco checks neither against the bytes left, and sizes its tables by them).
  // Under an 8 GiB limit both are refused before Draco allocates; without the estimate each
  // load succeeded after Draco failed, leaving a skipped primitive behind.
  setMemoryLimit(uint64_t(8) << 30);
  const auto sequential = loadGltfFromMemory(dracoBoxWithBitstream(dracoHeader(0, {1, 0xFFFFFFFFull}, 24)), "points.glb", "");
  const auto edgebreaker = loadGltfFromMemory(dracoBoxWithBitstream(dracoHeader(1, {1000, 700'000'000, 0, 0}, 24)), "faces.glb", "");
  // Counts within the limit still reach Draco, which rejects the bytes that are not there.
  GltfStats stats;
  const auto small = loadGltfFromMemory(dracoBoxWithBitstream(dracoHeader(0, {1, 1000}, 24)), "small.glb", "",
                                        InstanceClass::kStatic, &stats);
  setMemoryLimit(0);
  ASSERT_FALSE(sequential.has_value());
  EXPECT_EQ(sequential.error().message.rfind("points.glb: key 'meshes[0].primitives[0].extensions.KHR_draco_mesh_compression': "
                                             "a Draco mesh of 1 triangles and 4294967295 points needs about ", 0), 0u)
      << sequential.error().message;
  ASSERT_FALSE(edgebreaker.has_value());
  EXPECT_EQ(edgebreaker.error().message.rfind("faces.glb: key 'meshes[0].primitives[0].extensions.KHR_draco_mesh_compression': "
                                              "a Draco mesh of 700000000 triangles and 1000 points needs about ", 0), 0u)
      << edgebreaker.error().message;
  EXPECT_NE(edgebreaker.error().message.find("(--max-memory)"), std::string::npos) << edgebreaker.error().message;
  ASSERT_TRUE(small.has_value()) << small.error().message;
  EXPECT_EQ(stats.primitives_skipped, 1u);
}

TEST(GltfDraco, TheDeclaredCountsOfTheSharedDracoFilesAreTheirDecodedOnes) {
  // The box: sequential, 12 faces, 24 points. The metadata box: edgebreaker with metadata
  // (skipped with Draco's own decoder), 12 faces, 8 encoded vertices (36 points once its
  // attribute seams are decoded). A header misread into other counts fails here.
  const std::vector<uint8_t> box = dracoBox();
  uint32_t json_bytes;
  std::memcpy(&json_bytes, box.data() + 12, 4);
  const size_t bin = 20 + json_bytes + 8;
  DracoDeclared declared;
  char error[160];
  ASSERT_TRUE(dracoDeclaredCounts(box.data() + bin, box.size() - bin, &declared, error, sizeof error)) << error;
  EXPECT_FALSE(declared.edgebreaker);
  EXPECT_EQ(declared.faces, 12u);
  EXPECT_EQ(declared.points, 24u);
  const std::vector<uint8_t> meta = readBytes(DRTV_TEST_ASSETS "/draco_boxmeta/buffer0.bin");
  ASSERT_TRUE(dracoDeclaredCounts(meta.data(), meta.size(), &declared, error, sizeof error)) << error;
  EXPECT_TRUE(declared.edgebreaker);
  EXPECT_EQ(declared.faces, 12u);
  EXPECT_EQ(declared.points, 8u);
  EXPECT_FALSE(dracoDeclaredCounts(meta.data(), 12, &declared, error, sizeof error));  // the counts cut off
  EXPECT_NE(std::string(error).find("truncated"), std::string::npos) << error;
  // Both load whole under a limit of 64 MB more than the test holds (their estimates are a few KB).
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0, resident_pages = 0;
  statm >> pages >> resident_pages;
  ASSERT_GT(resident_pages, 0u);
  for (const char* path : {DRTV_TEST_ASSETS "/draco_box/Box_Draco.glb", DRTV_TEST_ASSETS "/draco_boxmeta/BoxMetaDraco.gltf"}) {
    setMemoryLimit(resident_pages * uint64_t(sysconf(_SC_PAGESIZE)) + (uint64_t(64) << 20));
    const auto w = loadGltf(path);
    setMemoryLimit(0);
    ASSERT_TRUE(w.has_value()) << w.error().message;
    EXPECT_EQ(w->triangleCount(), 12u) << path;
  }
}

// A glTF (JSON) with one triangle whose POSITION accessor has byte offset `offset`.
std::vector<uint8_t> triangleWithAccessorOffset(uint64_t offset) {
  // 3 float3 positions, as base64 of their 36 little-endian bytes: (0,0,0), (1,0,0), (0,1,0).
  const std::string positions = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
  const std::string text = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],)"
                           R"("meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],)"
                           R"("buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,)" + positions + R"("}],)"
                           R"("bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],)"
                           R"("accessors": [{"bufferView": 0, "byteOffset": )" + std::to_string(offset) +
                           R"(, "componentType": 5126, "count": 3, "type": "VEC3"}]})";
  return {text.begin(), text.end()};
}

TEST(GltfAccessors, AnOffsetThatWrapsAroundIsRejectedNotRead) {
  // 2^64 - 16: added to the view's offset unchecked, the start wrapped around and passed the
  // end check, and the loader read 16 bytes before the buffer (UBSan: pointer overflow).
  GltfStats stats;
  const auto w = loadGltfFromMemory(triangleWithAccessorOffset(18446744073709551600ull), "wrap.gltf", "",
                                    InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 0u);
  EXPECT_EQ(stats.primitives_skipped, 1u);
  ASSERT_FALSE(w->notes.empty());
  EXPECT_NE(w->notes.back().find("lies past bufferView 0"), std::string::npos) << w->notes.back();
  // The same file with offset 0 is a good triangle: only the offset made it bad.
  const auto good = loadGltfFromMemory(triangleWithAccessorOffset(0), "good.gltf", "");
  ASSERT_TRUE(good.has_value()) << good.error().message;
  EXPECT_EQ(good->triangleCount(), 1u);
}

TEST(GltfNodes, AHierarchyAsDeepAsTheFileHasNodesLoadsEveryNode) {
  // Found by probing the node walk beside fuzz_gltf: a chain of 3,000 nodes, each the child of
  // the one before, overflowed the stack of the recursive walk under ASan. 100,000 overflow it
  // in any build; the walk now keeps its own stack.
  constexpr int kNodes = 100000;
  json doc = json::parse(triangleWithAccessorOffset(0));
  json nodes = json::array();
  for (int i = 0; i < kNodes; ++i) {
    json node = {{"mesh", 0}};
    if (i + 1 < kNodes) node["children"] = {i + 1};
    nodes.push_back(node);
  }
  doc["nodes"] = nodes;
  const std::string text = doc.dump();
  GltfStats stats;
  const auto w = loadGltfFromMemory(std::vector<uint8_t>(text.begin(), text.end()), "chain.gltf", "",
                                    InstanceClass::kStatic, &stats);
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->instances.size(), size_t(kNodes));
  EXPECT_EQ(stats.cycles_skipped, 0u);
  EXPECT_EQ(w->instances.back().name, "chain.gltf: node " + std::to_string(kNodes - 1));
}

// The one-triangle glTF with "extras" nested `depth` arrays deep.
std::vector<uint8_t> triangleWithExtrasDepth(int depth) {
  json doc = json::parse(triangleWithAccessorOffset(0));
  doc["extras"] = "@";
  std::string text = doc.dump();
  const size_t at = text.find("\"@\"");
  text.replace(at, 3, std::string(size_t(depth), '[') + std::string(size_t(depth), ']'));
  return {text.begin(), text.end()};
}

TEST(GltfJson, NestingDeeperThan256LevelsIsAnErrorNamingTheByte) {
  // Found by probing tinygltf beside fuzz_gltf: "extras" 20,000 arrays deep overflowed the stack
  // in tinygltf's recursive conversion to its Value type (ASan stack-overflow).
  const auto deep = loadGltfFromMemory(triangleWithExtrasDepth(20000), "deep.gltf", "");
  ASSERT_FALSE(deep.has_value());
  EXPECT_EQ(deep.error().message.rfind("deep.gltf: byte ", 0), 0u) << deep.error().message;
  EXPECT_NE(deep.error().message.find("JSON nested deeper than 256 levels"), std::string::npos) << deep.error().message;
  // 255 arrays inside the top-level object: 256 levels, still a file.
  const auto fine = loadGltfFromMemory(triangleWithExtrasDepth(255), "fine.gltf", "");
  ASSERT_TRUE(fine.has_value()) << fine.error().message;
  EXPECT_EQ(fine->triangleCount(), 1u);
}

TEST(GltfContainer, ABinChunkLongerThanTheFileIsAnErrorNamingItsByte) {
  // Found by fuzz_gltf (build/fuzz/artifacts/gltf-crash-6bdc8c11...): a GLB whose BIN chunk length
  // claims 8 bytes more than the file holds passed tinygltf's check, which forgets the chunk's
  // own 8-byte header, and tinygltf copied the buffer from past the end (ASan
  // container-overflow). Here: BoxTextured.glb with its BIN length grown by 4 (still aligned).
  std::vector<uint8_t> glb = readBytes(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF-Binary/BoxTextured.glb");
  uint32_t json_bytes, bin_bytes;
  std::memcpy(&json_bytes, glb.data() + 12, 4);
  const size_t bin_at = 20 + json_bytes;
  std::memcpy(&bin_bytes, glb.data() + bin_at, 4);
  ASSERT_EQ(bin_at + 8 + bin_bytes, glb.size());  // the untouched file is exact
  ASSERT_TRUE(loadGltfFromMemory(glb, "box.glb", "").has_value());
  bin_bytes += 4;
  std::memcpy(glb.data() + bin_at, &bin_bytes, 4);
  const auto w = loadGltfFromMemory(glb, "long_bin.glb", "");
  ASSERT_FALSE(w.has_value());
  EXPECT_EQ(w.error().message, "long_bin.glb: byte " + std::to_string(bin_at) + ": BIN chunk of " +
                                   std::to_string(bin_bytes) + " bytes runs past the " + std::to_string(glb.size()) +
                                   "-byte GLB");
}

TEST(GltfContainer, ATruncatedDracoGlbStaysTruncated) {
  // Found by fuzz_gltf (build/fuzz/artifacts/gltf-crash-6bdc8c11...): Box_Draco.glb cut 8 bytes
  // short, its header still claiming the full length. Dropping the Draco primitives' "indices"
  // rewrote the header with the true size, which made the cut file look whole to tinygltf, and it
  // copied the BIN chunk from past the end (ASan container-overflow). It must be refused.
  std::vector<uint8_t> glb = dracoBox();
  ASSERT_GT(glb.size(), 8u);
  glb.erase(glb.end() - 8, glb.end());
  const auto w = loadGltfFromMemory(glb, "short_draco.glb", "");
  ASSERT_FALSE(w.has_value());
  EXPECT_EQ(w.error().message.rfind("short_draco.glb: glTF error: ", 0), 0u) << w.error().message;
}

TEST(GltfImages, APngWithAnEmptyIdatChunkIsIgnoredNotDecoded) {
  // Found by fuzz_gltf (build/fuzz/artifacts/gltf-crash-30740ce7...): stb_image copies an empty
  // IDAT chunk with memcpy(NULL, src, 0) (UBSan: null pointer passed as argument 1). A 1x1 grey
  // PNG whose first IDAT chunk is empty, the data in a second one, as the box's texture.
  const std::string png = "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAAAElEQVQ1rwYeAAAADElEQVR4nGNoaGgAAAMEAYFL09IQAAAAAElFTkSuQmCC";
  json doc = json::parse(triangleWithAccessorOffset(0));
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}, {"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}}}}};
  doc["textures"] = {{{"source", 0}}};
  doc["images"] = {{{"uri", "data:image/png;base64," + png}}};
  const std::string text = doc.dump();
  const auto w = loadGltfFromMemory(std::vector<uint8_t>(text.begin(), text.end()), "empty_idat.gltf", "");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->meshes.at(0).albedo, glm::vec3(0.5f));  // baseColorFactor alone
  bool noted = false;
  for (const std::string& note : w->notes) noted |= note.find("empty IDAT chunk") != std::string::npos;
  EXPECT_TRUE(noted);
}

TEST(GltfImages, AnImageInABufferViewGivesTheSameAlbedoAsTheSameImageByUri) {
  // The same box and texture, the image once in the GLB's BIN chunk and once as a .png file.
  const auto glb = loadGltf(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF-Binary/BoxTextured.glb");
  const auto gltf = loadGltf(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF/BoxTextured.gltf");
  ASSERT_TRUE(glb.has_value() && gltf.has_value());
  EXPECT_EQ(glb->meshes.at(0).albedo, gltf->meshes.at(0).albedo);
  EXPECT_LT(glb->meshes.at(0).albedo.r, 1.f);  // the texture was decoded, not ignored
}

TEST(GltfImages, AnImageBufferViewPastItsBufferIsIgnoredNotRead) {
  // Found by fuzz_gltf (build/fuzz/artifacts/gltf-crash-c86b26dc...): BoxTextured.glb with the
  // image's bufferView made longer than the BIN chunk; tinygltf passed byteOffset + byteLength to
  // stb_image unchecked, which read 2187 bytes past the buffer (ASan heap-buffer-overflow).
  const std::vector<uint8_t> original = readBytes(DRTV_ASSIMP_GLTF2 "/BoxTextured-glTF-Binary/BoxTextured.glb");
  int view = -1;
  const auto glb = editGlbJson(original, [&](json& d) {
    view = d["images"][0]["bufferView"].get<int>();
    d["bufferViews"][size_t(view)]["byteLength"] = d["bufferViews"][size_t(view)]["byteLength"].get<int>() + 4096;
  });
  ASSERT_GE(view, 0);
  const auto w = loadGltfFromMemory(glb, "long_image_view.glb", "");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->triangleCount(), 12u);
  EXPECT_EQ(w->meshes.at(0).albedo, glm::vec3(1.f));  // baseColorFactor alone (white)
  bool noted = false;
  for (const std::string& note : w->notes) noted |= note.find("image 0 not decoded") != std::string::npos;
  EXPECT_TRUE(noted);
}

}  // namespace
}  // namespace drtv::worlds

namespace drtv::worlds {
namespace {

using test_data::base64;

TEST(GltfImages, APngChunkLongerThanTheFileIsIgnoredBeforeAnythingIsAllocatedForIt) {
  // Found by fuzz_gltf (build/fuzz/artifacts/gltf2-oom-64a08e83..., second long run): a 4.7 KB
  // file whose PNG declared an IDAT chunk of about 2 GiB; stb_image grew its buffer to the declared
  // length before reading (libFuzzer: malloc(2147483648), over the 2 GB limit). A 1x1 PNG whose
  // IDAT chunk claims 0x7ffffff0 bytes, as the box's texture: refused, noted, the factor kept.
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n',
                              0, 0, 0, 13, 'I', 'H', 'D', 'R', 0, 0, 0, 1, 0, 0, 0, 1, 8, 2, 0, 0, 0, 0x90, 0x77, 0x53, 0xde,
                              0x7f, 0xff, 0xff, 0xf0, 'I', 'D', 'A', 'T', 0x78, 0x9c, 0x63, 0x68, 0x68, 0x68, 0, 0, 3, 4, 1, 0x81};
  json doc = json::parse(triangleWithAccessorOffset(0));
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1}}, {"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}}}}};
  doc["textures"] = {{{"source", 0}}};
  doc["images"] = {{{"uri", "data:image/png;base64," + base64(png)}}};
  const std::string text = doc.dump();
  const auto w = loadGltfFromMemory(std::vector<uint8_t>(text.begin(), text.end()), "long_idat.gltf", "");
  ASSERT_TRUE(w.has_value()) << w.error().message;
  EXPECT_EQ(w->meshes.at(0).albedo, glm::vec3(0.5f));
  bool noted = false;
  for (const std::string& note : w->notes) noted |= note.find("PNG chunk longer than the file") != std::string::npos;
  EXPECT_TRUE(noted);
}

}  // namespace
}  // namespace drtv::worlds
