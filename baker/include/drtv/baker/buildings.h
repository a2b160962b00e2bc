// drtv/baker/buildings.h — the bake report per building (issue 35): what the fine level holds
// under each roof.
//
// A building here is what the probes say, not what an artist named: the covered probes
// (kProbeCovered: under a roof, a storey, an overhang; each carries a visibility map) joined
// whenever two stand within `join_m` of each other horizontally, at any height (storeys stacked
// over one footprint are one building; a street wider than `join_m` between two blocks parts
// them). The default, 8 m, is two steps of placement's 4 m lattice under a roof (PlacementSettings):
// a wing's probes stand up to that far apart where placement kept none between them. Measured on
// the town (1 km², 12 m streets): 4.5 m reported 3,129 buildings, 2,583 of under 10 probes; 6 m
// 1,047 and 660; 8 m 222 and 6; 11.5 m 193 and 0. Two buildings closer than 8 m are reported as
// one. Its storeys are counted up each column of probes (those whose horizontal positions round
// to the same point of a `column_m` grid): placement keeps at most one covered probe a storey in a column
// (min_vertical_m, 3 m), so a probe's rank in its column, bottom up, is its storey, whatever the
// height of its wing's ground or how far the inside test lifted it; a probe placed up a space
// taller than a storey (kProbeStacked, placement.h covered_stack_m) keeps the rank of the one
// under it, so a 6.5 m hall is one storey with two probes a column. (Clusters of probe heights
// did not give the storeys: the town's wings stand on ground up to 0.7 m apart and lifted probes
// fill the gaps between floors, chaining the eight storeys of its test block into four.) The top
// storeys holding fewer than `small_level` of the ground storey's probes fold into the one below:
// a stair's top, a probe over a parapet. A probe the inside test moved sideways starts a column
// of its own and counts on the ground storey. Its rooms are the interiors whose designated probe
// (kProbeInterior) it holds: the artist's and those the bake found (rooms.h). Its bytes are its
// probes' records and visibility maps.
//
// Sectors are added one at a time (the bake's packing reads each once); a building spanning
// sectors is joined across them. Deterministic: the same sectors in any order give the same list.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/sector.h"

namespace drtv::baker {

struct BuildingStats {
  glm::dvec2 min{0.0}, max{0.0};        // footprint of its probes, world metres
  double bottom_z = 0.0, top_z = 0.0;   // its lowest and highest probe
  size_t probes = 0;                    // covered probes
  std::vector<size_t> storey_probes;    // probes per storey, bottom up
  size_t rooms = 0;                     // interiors whose designated probe it holds
  size_t bytes = 0;                     // probe records + visibility maps
  int sectors = 0;                      // sectors it spans
};

struct BuildingOptions {
  double join_m = 8.0;        // covered probes this close horizontally are one building
  double column_m = 0.5;      // probes this close horizontally are one column (a storey each)
  double small_level = 0.05;  // a top storey under this fraction of the ground's probes folds
};

class BuildingCollector {
 public:
  explicit BuildingCollector(BuildingOptions options = {}) : options_(options) {}
  // The covered probes of `sector` (its other probes are the far field's).
  void addSector(const Sector& sector);
  // Every building, the most probes first (ties: the lowest min corner, x then y).
  std::vector<BuildingStats> buildings() const;

 private:
  struct Probe {
    glm::dvec3 position;
    uint16_t interior;  // the interior's index + 1 when designated, else 0
    SectorKey key;
    bool stacked;       // kProbeStacked: counted on the storey of the probe under it
  };
  BuildingOptions options_;
  std::vector<Probe> probes_;
};

}  // namespace drtv::baker
