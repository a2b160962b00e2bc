// gltf_container.h — what the glTF loader (gltf.cpp) checks and rewrites in a file's bytes
// before tinygltf 2.7 parses them: the faults of that version that fuzzing found, and the Draco
// primitives it refuses. Private to drtv::worlds.
//
//  [1] glTF 2.0 specification 2.0.1, 4.4 (GLB file format: header, JSON chunk, BIN chunk).
//  [2] KHR_draco_mesh_compression extension specification.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace drtv::worlds {

// tinygltf converts "extras" and "extensions" into its Value type recursively, a stack frame per
// level: a fuzzed "extras" 20,000 arrays deep overflowed the stack (ASan). glTF's own structure
// is a few levels deep, so text nested deeper than this is refused before tinygltf sees it.
inline constexpr int kMaxJsonDepth = 256;

// The byte offset in `text` where JSON arrays and objects first nest deeper than kMaxJsonDepth,
// or npos. Brackets inside strings do not count.
size_t jsonTooDeepAt(std::string_view text);

// tinygltf 2.7 built without its own Draco path (tinygltf_impl.cpp) rejects a Draco primitive
// whose indices accessor has no bufferView, which the extension prescribes [2]. The loader takes a
// Draco primitive's triangles from the bitstream and never reads that accessor, so "indices" is
// removed from such primitives before tinygltf sees the JSON. Returns the rewritten JSON, or
// nothing when there is nothing to remove or the JSON does not parse (tinygltf reports that).
std::optional<std::string> withoutDracoIndices(std::string_view text);

// The same for a GLB container [1]: a new JSON chunk (padded with spaces to 4 bytes), the chunks
// after it unchanged. Nothing when the container is malformed (tinygltf reports that).
std::optional<std::vector<uint8_t>> glbWithoutDracoIndices(std::span<const uint8_t> glb);

// What is wrong with a GLB's BIN chunk bound [1], or "" when it fits. tinygltf 2.7 checks the
// chunk's length against the file as if the chunk had no 8-byte header, then reads the length
// from after the header: a fuzzed GLB with the BIN length 8 too large made it read past the end
// (ASan). Only that bound is checked here; tinygltf checks the rest of the container.
std::string glbBinChunkError(std::span<const uint8_t> glb);

}  // namespace drtv::worlds
