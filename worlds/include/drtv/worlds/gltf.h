// drtv/worlds/gltf.h — glTF 2.0 (.gltf, .glb) scenes as Worlds, KHR_draco_mesh_compression
// included.
//
// Conventions of the result:
//  - glTF is Y-up; drtv is Z-up. A glTF point (x, y, z) becomes (x, -z, y): a right-handed
//    rotation of +90 deg about X (matrix C). Mesh positions are stored converted (C p) and each
//    node's world matrix M becomes C M C^-1, so that instance.transform * position = C M p.
//  - One drtv Mesh per glTF primitive (each primitive has one material, hence one albedo),
//    named "<file>: mesh '<name>' primitive <k>"; one Instance per (node, primitive).
//  - Materials (docs/world-format.md, "Materials"; counts in World::materials, one note each):
//    albedo = baseColorFactor.rgb (linear) x the mean linear colour of the base-colour texture
//    when it has one (texels are sRGB-decoded before averaging) x (1 - metallic), clamped to
//    [0, 1]; metallic = metallicFactor (glTF default 1) x the mean blue of the
//    metallic-roughness texture. No material: albedo 1, non-metallic.
//    alphaMode MASK: a primitive whose baseColorFactor alpha is below alphaCutoff is skipped,
//    any other is opaque (texture alpha not applied). BLEND: mean alpha (factor x texture mean)
//    >= 0.5 opaque, else skipped. Emission = emissiveFactor x the mean linear emissive texture
//    colour x KHR_materials_emissive_strength, on Mesh::emission; an emitter's albedo is 0 and
//    loadGltf turns it into point lights (emissiveLights, world.h). doubleSided sets
//    Mesh::double_sided: a surface from both sides for the bake and the path tracer.
//  - Triangle lists, strips and fans are loaded (strips and fans become lists, see
//    gltfStripToList / gltfFanToList); points and lines are skipped with a note.
//  - Triangles that touch a NaN/Inf position or have zero area are dropped and counted; the
//    counts go to World::notes and to GltfStats.
//  - Scenes: the default scene, else scene 0, else every root node (a node nobody lists as a
//    child). A node reached again while it is its own ancestor (a cycle) is skipped with a note.
// Thread-safety: loadGltf may run concurrently on different files.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

// What loadGltf read and what it left out. Counts are per glTF primitive read (not per
// instance): a mesh used by 3 nodes counts once.
struct GltfStats {
  size_t primitives_loaded = 0;     // primitives that became a drtv Mesh
  size_t primitives_skipped = 0;    // unsupported mode, bad accessor, out-of-range index...
  size_t triangles_read = 0;        // triangles before dropping (after strip/fan conversion)
  size_t dropped_nonfinite = 0;     // triangles touching a NaN/Inf position
  size_t dropped_degenerate = 0;    // zero-area triangles (repeated index or collinear)
  size_t cycles_skipped = 0;        // node references that would recurse
  // Per instance (a mesh used by 3 nodes counts 3 times): triangles read and kept. Their
  // difference is what was dropped from World::triangleCount().
  size_t instanced_triangles_read = 0;
  size_t instanced_triangles_kept = 0;
};

// Loads a .gltf or .glb file as a World whose instances all have class `cls` and whose name is
// the file's name. Sky and interiors are left at their defaults; lights are the emissive
// materials' (emissiveLights); effects are defaultEffects() of the result. Fails (message
// starting with the file's path) when tinygltf cannot parse the file or its buffers; a bad
// primitive inside an otherwise good file is skipped with a note instead. `stats` may be null.
Result<World> loadGltf(const std::filesystem::path& path, InstanceClass cls = InstanceClass::kStatic,
                       GltfStats* stats = nullptr);

// Loads glTF from bytes in memory, as loadGltf does from a file: GLB when the bytes start with
// the magic "glTF", glTF JSON otherwise. `name` prefixes every message and names the World;
// relative buffer and image URIs resolve against `base_dir`. For untrusted bytes (the fuzz
// target, docs/fuzzing.md) as for files: bad input is an Error or a note, never an abort.
Result<World> loadGltfFromMemory(std::span<const uint8_t> bytes, const std::string& name,
                                 const std::filesystem::path& base_dir, InstanceClass cls = InstanceClass::kStatic,
                                 GltfStats* stats = nullptr);

// Triangle strip -> triangle list, glTF 2.0 spec 3.7.2.1: triangle i of the strip is
// (v[i], v[i+1+i%2], v[i+2-i%2]). Fewer than 3 vertices give no triangles.
std::vector<uint32_t> gltfStripToList(const std::vector<uint32_t>& strip);
// Triangle fan -> triangle list, glTF 2.0 spec 3.7.2.1: triangle i is (v[i+1], v[i+2], v[0]).
std::vector<uint32_t> gltfFanToList(const std::vector<uint32_t>& fan);

}  // namespace drtv::worlds
