// drtv/worlds/summary.h — what `drtv info` prints about a World.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "drtv/formats/sector.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {


struct WorldSummary {
  std::string name;
  size_t meshes = 0;
  size_t instances = 0;
  size_t triangles = 0;                      // instanced (World::triangleCount)
  std::array<size_t, 4> instances_by_class{};  // indexed by InstanceClass
  Bounds bounds;                             // world metres
  // Sectors the bounds touch: keys floor(x/64)..floor(x/64) x floor(y/64)..; all 0 when empty.
  int64_t sector_min_x = 0, sector_max_x = 0, sector_min_y = 0, sector_max_y = 0;
  size_t sectors = 0;                        // (max_x-min_x+1)(max_y-min_y+1), 0 for an empty world
  uint32_t effects = 0;
  bool effects_explicit = false;
  size_t lights = 0;
  size_t interiors = 0;
  size_t notes = 0;
  MaterialCounts materials;                  // World::materials
};

// The material counts as (name, count) pairs, in one order for every report (drtv info, the bake
// report): "materials", "opaque", "mask_kept", ..., "emissive_lights".
std::vector<std::pair<const char*, size_t>> materialCountFields(const MaterialCounts& counts);
// One line for people: "materials: 5 (opaque 5, mask kept 0, ...)".
std::string materialCountsLine(const MaterialCounts& counts);

// Notes for people (the reports' Markdown, issue 35: a building of 1,945 materials printed 1,945
// near-identical material lines): notes of one form, the same text once every number and every
// quoted name is taken out, are kept up to kNotesOfAForm; the rest of the form is one line,
// "... and 1,942 more like these: material: # '…': metallic #: ...". Each form stays where it
// first appears, its notes in their order. The JSON reports keep every note.
inline constexpr size_t kNotesOfAForm = 3;
std::vector<std::string> collapseNotes(std::span<const std::string> notes);

// Computes the summary. O(instances + vertices). Thread-safe for a World not being mutated.
WorldSummary summarize(const World& world);

// Multi-line human-readable text ("triangles: 123\n..."), for `drtv info`.
std::string toString(const WorldSummary& summary);

}  // namespace drtv::worlds
