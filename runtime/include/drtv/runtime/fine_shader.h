// drtv/runtime/fine_shader.h — the fine level near surfaces (ProbeCache::fineLookup, issue 35) as
// the shaders sample it: runtime/shaders/fine.glsl and fine.hlsl, drtvFine(position, normal).
//
// The engine packs, when the probes' colours change or the camera crosses a cell, the resident
// covered probes around the camera into one uniform block and three storage buffers:
//   constants   FineShaderConstants (std140 / cbuffer packing, 64 bytes, drawn below)
//   probes      per probe FineShaderProbe (std430, 80 bytes): world position, four basis colours
//   visibility  per probe its map's kVisValuesPerProbe bytes (visibility.h) as 128 uints, byte i
//               of the map in bits 8 (i mod 4) of uint i / 4
//   cells       the box around the camera as a grid of cell_m cells, x fastest: per cell two uints
//               (first, count) indexing this same buffer, then the lists: each cell's probes that
//               lie within the lookup's radius of some point of the cell
// drtvFine moves the point along its normal by normal_bias_m, finds its cell and weighs the
// probes the cell lists exactly as fineLookup weighs the resident ones within its radius (the
// same probes, in another order), and returns the weighted colours shaded for the normal (fc3's
// basis weights or sh-l1's band-1 sum, a compile-time define as in ambient.glsl) and the weight.
// The weight fades to 0 over the box's outermost `fade_m` (one cell): beyond the box the far
// field lights the point alone, and the level follows the camera a cell at a time. The engine
// blends ambient = mix(ambient, fine.rgb, fine.a).
//
// Memory: 80 + 512 bytes a packed probe, 8 bytes a cell and 4 a listed probe. The default box
// (64 x 64 x 48 m, 4 m cells: 3,072 cells) over a block of 4-storey courtyard buildings packs 606
// probes in 0.43 MB (tests/runtime/fine_shader_run_test.cpp); the volumes take 1.77 MB.
// Runtime::update packs it when RuntimeOptions::fine_shader is set and the box's corner, the
// colours or the resident sectors changed (Runtime::fineLevel).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/runtime/probe_cache.h"

namespace drtv::runtime {

// The uniform block both shaders declare (FineConstants):
//   offset  0  box_min (vec3)   12 cell_m
//          16  box_max (vec3)   28 radius_m
//          32  cells (ivec3)    44 normal_bias_m
//          48  min_visibility   52 full_weight   56 fade_m   60 probes
struct FineShaderConstants {
  float box_min[3];
  float cell_m;
  float box_max[3];
  float radius_m;
  int32_t cells[3];
  float normal_bias_m;
  float min_visibility;
  float full_weight;
  float fade_m;
  uint32_t probes;
};
static_assert(sizeof(FineShaderConstants) == 64);

struct FineShaderProbe {
  float position[4];    // xyz world metres, w 0
  float colours[4][4];  // basis b's colour rgb, a 0
};
static_assert(sizeof(FineShaderProbe) == 80);

struct FineShaderOptions {
  glm::dvec3 half_extent_m{32.0, 32.0, 24.0};  // the box around the camera (at most 1,024 cells an axis: checked)
  double cell_m = 4.0;                         // its cells (and the fade at its edge); not positive: 4
  FineOptions lookup;                          // radius, normal bias, visibility floor, full weight
};

struct FineShaderData {
  FineShaderConstants constants{};
  std::vector<FineShaderProbe> probes;
  std::vector<uint32_t> visibility;
  std::vector<uint32_t> cells;
  size_t bytes() const {
    return sizeof constants + probes.size() * sizeof(FineShaderProbe) + (visibility.size() + cells.size()) * sizeof(uint32_t);
  }
};

// The buffers for the box around `camera` (its corner snapped to whole cells) from the resident
// covered probes of `cache` and their current colours. An empty level (no probe: every drtvFine
// weight 0) when o.lookup is disabled, its radius is not positive, or the camera is not finite.
FineShaderData packFineLevel(const ProbeCache& cache, const glm::dvec3& camera, const FineShaderOptions& o);

// The corner of the box packFineLevel packs around `camera`, snapped to whole cells: the level's
// cells and lists change only when it does (NaN components for a non-finite camera).
glm::dvec3 fineBoxCorner(const glm::dvec3& camera, const FineShaderOptions& o);

// The factor by which the shaders fade the fine level's weight at `at` (the point moved along its
// normal): 1 deeper than fade_m inside the box, falling linearly to 0 at its faces, 0 outside.
float fineShaderFade(const FineShaderConstants& k, const glm::dvec3& at);

}  // namespace drtv::runtime
