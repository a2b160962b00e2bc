// The slow reference for the sweep (tests only): see sweep_reference.cpp.
#pragma once

#include "drtv/sweep/sweep.h"

namespace drtv::sweep::reference {

// sweep() as first built (issue 15): same contract, preconditions and results as sweep.h's sweep(),
// up to float rounding.
SweptGrid sweepReference(const MaterialGrid& material, const SkyInput& sky, const SweptGrid* parent, const SweepOptions& options);

}  // namespace drtv::sweep::reference
