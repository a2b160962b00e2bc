// Private: SectorStats <-> JSON, shared by the sector sidecar files and the bake report.
#pragma once

#include <nlohmann/json.hpp>

#include "drtv/baker/bake.h"

namespace drtv::baker {

nlohmann::json toJson(const SectorStats& s);
// Missing keys read as 0 (an older sidecar); never throws.
SectorStats sectorStatsFromJson(const nlohmann::json& j);

}  // namespace drtv::baker
