// A replaced global operator new for the streamer tests: it counts the bytes every thread has
// allocated and not yet freed, so that memory budgets are asserted from real allocations rather
// than from formulas. (zstd's contexts use malloc directly and are not counted; they are per
// I/O thread, not per sector.)
#pragma once

#include <cstdint>

namespace drtv::testing {

// Bytes requested through operator new and not yet deleted, all threads, since start-up.
int64_t liveHeapBytes();
// Number of operator new calls since start-up.
int64_t heapAllocations();
// The most liveHeapBytes() has been since the last resetHeapPeak() (which sets it to now).
int64_t heapPeakBytes();
void resetHeapPeak();

}  // namespace drtv::testing
