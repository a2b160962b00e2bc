// terrain.h (private) — regular heightfields: seeded noise, 16-bit PNG heightmaps, meshing.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

// Heights on a regular grid of nx x ny vertices, `spacing_m` apart, vertex (0,0) at `origin`
// (world metres, x east, y north). Triangulated as in heightfieldMesh(): each cell split along
// the diagonal from (i,j) to (i+1,j+1).
struct Heightfield {
  uint32_t nx = 0, ny = 0;
  double spacing_m = 1.0;
  glm::dvec2 origin{0.0};
  std::vector<float> heights_m;  // row-major, index j * nx + i; metres above z = 0

  float at(uint32_t i, uint32_t j) const { return heights_m[size_t(j) * nx + i]; }
  // Height of the triangulated surface at world (x, y), clamped to the grid's edge.
  double heightAt(double x, double y) const;
  bool contains(double x, double y) const;
};

// Triangle mesh of `hf` in local coordinates relative to hf.origin (so that the instance
// translation carries the large offsets), 2 (nx-1)(ny-1) triangles.
Mesh heightfieldMesh(const Heightfield& hf, std::string name, glm::vec3 albedo);

// A square noise terrain `size_m` wide centred on (0,0): fBm value noise with features about
// `feature_m` wide, heights in [0, height_m]. Vertex spacing is `resolution_m` (rounded so that
// the edge lands exactly on size_m).
Heightfield noiseHeightfield(double size_m, double resolution_m, double height_m, double feature_m, uint64_t seed);

// A 16-bit (or 8-bit) grayscale PNG heightmap mapped onto a square `size_m` wide centred on
// (0,0): white = height_m, black = 0. `resolution_m` <= 0 uses one vertex per texel, else the
// image is resampled bilinearly. The image must be square; RGB(A) is accepted only when every
// texel is grey (R = G = B). Errors name `path`.
Result<Heightfield> loadHeightmapPng(const std::filesystem::path& path, double size_m, double height_m,
                                     double resolution_m);

// Why stb_image must not be given `bytes`, or nullptr. Debian's stb_image copies an empty PNG
// IDAT chunk with memcpy(NULL, src, 0), undefined behaviour (UBSan, found by fuzz_gltf); such a
// PNG is refused before stb_image sees it. Every stb_image call in drtv asks this first.
const char* stbImageRefusal(const unsigned char* bytes, size_t size);

// Decodes a PNG/JPEG/... file in memory to 16-bit channels (implemented beside tinygltf, which
// owns the stb_image implementation). Returns false with `error` set on failure.
// Reads an image's size and channel count from its header alone; false if not an image.
bool peekImageSize(const unsigned char* bytes, size_t size, int& width, int& height, int& channels);
bool decodeImage16(const unsigned char* bytes, size_t size, int& width, int& height, int& channels,
                   std::vector<uint16_t>& pixels, std::string& error);

}  // namespace drtv::worlds
