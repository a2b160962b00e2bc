// draco_mesh.h — KHR_draco_mesh_compression decoding behind a plain-data interface.
//
// Only built-in types cross this header, never a std:: type: Debian's libdraco is built against
// libstdc++, and the fuzz tree (docs/fuzzing.md) builds drtv against libc++; draco_mesh.cpp is
// the one translation unit that includes Draco's headers, and the fuzz tree compiles it against
// libstdc++ like Draco itself. In the normal g++ build everything uses libstdc++ and nothing
// differs. It also replaces tinygltf 2.7's own Draco path, which indexes bufferViews, buffers,
// accessors and attributes without checking them (any glTF could make it read out of bounds).
#pragma once

#include <cstddef>
#include <cstdint>

namespace drtv::worlds {

// A decoded Draco mesh: positions (3 floats per point, glTF space, as Draco returns them after
// dequantisation) and a triangle list of point indices, all < vertex_count. Owns its arrays
// (malloc'd): release with freeDracoMesh.
struct DracoMesh {
  float* positions = nullptr;   // vertex_count x 3
  uint32_t* indices = nullptr;  // index_count = 3 x faces
  size_t vertex_count = 0;
  size_t index_count = 0;
};

// Decodes the Draco bitstream `bytes[0, size)` as a triangle mesh and reads the attribute whose
// unique id is `position_id` (the glTF extension's attributes.POSITION) as 3 floats per point.
// On success fills `out` and returns true. On failure (not a Draco mesh, no such attribute,
// an index or value out of range, out of memory) returns false, leaves `out` empty and writes a
// NUL-terminated reason into error[0, error_size) (truncated). Never aborts, never throws.
// Thread-safe.
bool decodeDracoMesh(const unsigned char* bytes, size_t size, int position_id, DracoMesh* out, char* error,
                     size_t error_size) noexcept;

// What a Draco bitstream declares before any of it is decoded: the counts the decoder sizes its
// arrays by. `faces` is the connectivity's face count; `points` the point count the attribute
// decoders allocate for (sequential meshes: the header's num_points; edgebreaker meshes: the
// encoded vertices plus one per split symbol, the size of its vertex tables). `edgebreaker` says
// which connectivity it is. Reads the header, skips the metadata with Draco's own decoder, and
// reads the connectivity's leading counts as Draco 1.5 does for every bitstream version it takes
// (1.0 to 2.2).
struct DracoDeclared {
  uint64_t faces = 0;
  uint64_t points = 0;
  bool edgebreaker = false;
};

// Fills `out` from the bitstream `bytes[0, size)` and returns true, or returns false with a reason
// in error[0, error_size) when the header or the counts cannot be read (the same bitstream would
// then fail to decode). Allocates nothing in proportion to the counts. Never aborts, never throws.
bool dracoDeclaredCounts(const unsigned char* bytes, size_t size, DracoDeclared* out, char* error,
                         size_t error_size) noexcept;

// Frees what decodeDracoMesh allocated and empties `mesh`. Null arrays are fine.
void freeDracoMesh(DracoMesh* mesh) noexcept;

}  // namespace drtv::worlds
