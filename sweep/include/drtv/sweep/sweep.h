// drtv/sweep/sweep.h — the top-down sweep (seed 001): sky and sun light carried down through a
// material grid one horizontal level at a time, into a light grid.
//
//  [1] ../shared/seeds/001, "Tracing light flow, updating the grids" and "Rendering".
//
// The model, per level from the top down ([1]; directions.h for the 26 directions and units):
//  - The level above the grid's top, and every cell outside the grid's sides, hold the light of
//    `edges`: the open sky (SkyInput) or a coarser swept grid sampled at the cell's centre
//    (trilinear), as [1]'s finer grids take their edge points from the coarser one. The coarser
//    grid is read no lower than the centre of its lowest cell wholly above the ground (clear_z):
//    a 16 m cell the terrain partly fills is dark on average, but the air above the ground in it
//    is not; on the island, reading it there made the 1 m grids' light 7 % too dark from their
//    top level down. The price: the canopy within that coarse cell does not shade the edges
//    (the finer grid's own material does, inside it).
//  - Each cell gathers, for each of the 17 down-going directions, the light leaving the cell of
//    the level above it came from (straight down, the 8 diagonals, and 4 cells sideways for the 8
//    near-horizontal ones), smoothed over that source and its 4 side neighbours (weights
//    `smoothing` and (1 - smoothing) / 4: [1]'s "weighted average of the lights of the source
//    cell and its neighbors"; it keeps the light's total, so energy is preserved). Every material
//    cell a gathered path crosses between its source and this cell attenuates it by
//    (1 - density)^length (lengths in cell units, by the segment between the cell centres), so
//    light never skips through an object ([1]); what those crossed cells stop is absorbed.
//  - In the cell itself a direction's light of path length l (|sweep_step| less what the crossed
//    cells took) passes as T = (1 - density)^l; of the rest I (1 - T), the share `reflectance` is
//    reflected and the remainder absorbed. The reflected light goes to all 26 outgoing
//    directions o in proportion to Omega_o f(o), f(o) = 1 - (1 - tau) (1 + cos) / 2, where
//    tau = 1 - density and cos the angle between the outgoing and the incoming travel direction:
//    [1]'s "forward reflected light is also multiplied by the pass-through factor, interpolated
//    between forward and backward". The proportions are normalised, so all of it leaves: light is
//    conserved except what is absorbed.
//  - A sealed cell, a full cell whose neighbours in the grid are all full (inside a hill; above the
//    grid's top is open, past its sides and below its bottom counts as full), gathers no light:
//    it stores none and sends none on. Its light could only be what the full cells around it
//    reflect into it, rock lit through rock: the seed's reflection sends part of what a ground
//    cell stops down and sideways into the ground, and level after level that crept into the
//    hill. The edges' light does not enter the ground through the grid's sides either. The
//    sweep skips long runs of sealed cells, which makes sectors with much ground faster.
//  - What leaves the cell downwards (I T + reflected) feeds the next level (ping-pong buffers of
//    float RGB, one level each); what is stored is the light halfway through the cell:
//    I sqrt(T) + reflected / 2 ([1]: "closer to the average incident light within the cell").
//  - The 9 up-going directions: the top-down pass stores only the light each cell reflects
//    upwards (halved, as above), as [1] does. With `bottom_up`, a second pass carries it up,
//    level by level from the bottom, through the same attenuation (the cells' reflection of the
//    up-going light is not carried on: that would need another downward pass).
//  - Direct sun: the sun is a bright disc in the sky (directions.h sunLight), carried like the
//    sky. The light grid stores the ambient without the sun's unscattered part unless
//    `direct_sun`: a second, reflection-free pass of the sun alone through the same grid gives
//    that part, which is subtracted (the reference's ambient leaves direct sun to the renderer,
//    reference.h). The sweep is linear in the light, so the difference is exactly the sun's
//    scattered light plus the sky's.
//
// Deterministic: a fixed order of operations, no threads inside; its row loops give the same bytes
// as AVX-512, AVX2 or baseline x86-64 code (the same operations in the same order, no FMA:
// compared on the benchmark's sector under every option). Thread-safe (no shared state beyond read-only tables
// built once).
#pragma once

#include <optional>

#include "drtv/sweep/directions.h"
#include "drtv/sweep/grid.h"

namespace drtv::sweep {

// The light above the atmosphere's bottom: per bin, without and with the sun.
struct SkyInput {
  LightVector sky{};  // skyLight()
  LightVector sun{};  // sunLight()
};

struct SweepOptions {
  bool bottom_up = false;    // carry the reflected up-going light up (see the header)
  bool direct_sun = false;   // store the sun's unscattered light too (the reference's ambient does not)
  bool keep_direct = false;  // keep the sun's unscattered light as its own grid (what a finer
                             // grid's edges need from this one)
  // Weight of the gathered source cell itself; the rest spread over its 4 side neighbours. [0, 1].
  // 0.6: the shadow of a 1-cell object 3 levels down keeps a core (tests), and the 17 directions'
  // streaks on the island's renders fade.
  float smoothing = 0.6f;
  // Also keep the light values unpacked (LightGrid::unpacked, in the direct grid too), which the
  // grids' lookups then read: what the R11G11B10 form costs, measured (the technique's
  // storage=float). The words are the same either way.
  bool keep_unpacked = false;
};

// A swept grid: its ambient light (LightGrid) and, with keep_direct, the sun's unscattered part.
struct SweptGrid {
  LightGrid light;
  std::optional<LightGrid> direct;
  bool light_has_direct = false;  // SweepOptions::direct_sun of the sweep
  SkyInput sky;                   // what it was swept under (for the edges above its top)
  // Per column (i + size.x j), from MaterialGrid::ground_z: the centre height (world metres) of
  // the lowest cell wholly above the ground; empty without ground_z. See the header.
  std::vector<float> clear_z;
  size_t bytes() const { return light.bytes() + (direct ? direct->bytes() : 0); }
};

// Sweeps `material` under `sky`, its edges from `parent` (a coarser grid of the same lighting,
// swept with keep_direct, or with direct_sun) or, without one, the open sky. Preconditions (bugs
// otherwise): a material grid of consistent sizes, density in [0, 1]; parent->direct present unless
// parent->light_has_direct.
SweptGrid sweep(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options);

// As sweep(), into `out`, whose buffers are refilled in place where they already have this grid's
// sizes: a re-sweep of the same material under new lighting (an hour of the day) allocates and
// zeroes nothing (a fresh 64 x 64 x 32 grid is 14.7 MB to zero first). `out` may hold anything
// (another grid, another sweep's options); afterwards it holds exactly what sweep() returns.
// Preconditions as sweep(), and `out` is not `*parent`.
void sweepInto(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options,
               SweptGrid& out);

}  // namespace drtv::sweep
