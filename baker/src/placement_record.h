// The placement journal's record (bake.cpp's placement pass, sector_journal.h): a sector's
// placed probes and its placement statistics, so that a resumed or sharded LPRT bake reads the
// placement back instead of placing again. Private to the baker.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "drtv/baker/bake.h"
#include "drtv/formats/error.h"

namespace drtv::baker::detail {

std::vector<uint8_t> encodePlacement(const SectorPlacement& p);
// The record's placement; an error (prefixed `where`) for a record of the wrong size or a
// non-finite position.
Result<SectorPlacement> decodePlacement(std::span<const uint8_t> bytes, const std::string& where);

}  // namespace drtv::baker::detail
