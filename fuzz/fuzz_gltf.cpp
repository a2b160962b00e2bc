// fuzz_gltf.cpp — libFuzzer target for the glTF/GLB loader (worlds/src/gltf.cpp: tinygltf for
// the container and JSON, Draco for KHR_draco_mesh_compression, drtv's accessor checks).
//
// The input is a .glb (starts with "glTF") or a .gltf (JSON); buffers and images must be
// embedded (data: URIs or the GLB chunk): relative URIs resolve against the current folder,
// where the fuzzer has nothing to find. Properties: never an abort, an out-of-bounds read, a
// leak or UB; what loads is a World whose instances name existing meshes, whose triangles index
// existing vertices and whose positions are finite. The loader's memory estimates (a Draco
// bitstream may declare billions of points in 40 bytes) run against a 1.5 GiB limit, under the
// 2 GiB -rss_limit_mb scripts/fuzz gives libFuzzer, so a refused input is an error, not an OOM.
// After meshoptimizer's tools/codecfuzz.cpp. Run: docs/fuzzing.md.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "drtv/formats/memory_limit.h"
#include "drtv/worlds/gltf.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  drtv::setMemoryLimit(uint64_t(1536) << 20);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  drtv::worlds::GltfStats stats;
  const auto world = drtv::worlds::loadGltfFromMemory(std::span<const uint8_t>(data, size), "fuzz.glb", "",
                                                      drtv::worlds::InstanceClass::kStatic, &stats);
  if (!world) return 0;
  for (const auto& instance : world->instances) DRTV_CHECK_LT(instance.mesh, world->meshes.size());
  for (const auto& mesh : world->meshes) {
    DRTV_CHECK_EQ(mesh.indices.size() % 3, 0u);
    for (uint32_t i : mesh.indices) DRTV_CHECK_LT(i, mesh.positions.size());
    for (const auto& p : mesh.positions) DRTV_CHECK(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
  }
  DRTV_CHECK_LE(stats.instanced_triangles_kept, stats.instanced_triangles_read);
  return 0;
}
