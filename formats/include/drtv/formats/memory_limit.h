// drtv/formats/memory_limit.h — memory as an input limit (issue 17): before a load or a bake
// allocates in proportion to what a file asks for (a terrain's cells, a vegetation count, an
// image's pixels), it estimates the bytes and asks checkMemory(); beyond what this process may
// use, the input is refused with an error naming the file, the key and the estimate, instead of
// ending in std::bad_alloc (or the kernel's OOM killer) gigabytes later.
//
// The limit is what the process may still allocate: the smallest of the machine's physical memory
// (sysconf) and a limit the program sets (drtv's --max-memory), each less the process's resident
// size, and the address-space and data-segment rlimits (RLIMIT_AS, RLIMIT_DATA) less what the
// process already uses of them. Estimates are of the peak a step adds, sized from
// the data structures it fills (each caller says how); they err high by tens of percent, never by
// factors, so a refusal means the step would have needed most of the limit.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "drtv/formats/error.h"

namespace drtv {

// Sets the process-wide limit in bytes (0 = none: only the machine's and the rlimits apply).
// Thread-safe; meant to be called once at start-up (drtv --max-memory).
void setMemoryLimit(uint64_t bytes);

struct MemoryLimit {
  uint64_t bytes = 0;  // what the process may still allocate (the limit less what it holds)
  std::string source;  // "physical memory", "RLIMIT_AS", "RLIMIT_DATA" or "--max-memory"
};
// The current limit (see the header). Thread-safe.
MemoryLimit memoryLimit();

// The most memory this process has held resident so far (getrusage's ru_maxrss), in bytes; 0 where
// the system does not say. What a bake reports as its peak, so that a farm task's memory request
// can be sized from a measurement (docs/baker.md). Thread-safe.
uint64_t peakResidentBytes();

// "1.5 GB", "640 MB", "12 KB", "512 B" (decimal units, as the message a person reads).
std::string formatBytes(uint64_t bytes);
// Parses "2G", "512M", "1.5GB", "64k", "1000000" (binary multiples: K = 1024). nullopt if not a
// positive size.
std::optional<uint64_t> parseBytes(const std::string& text);

// Ok when `estimate_bytes` fits in memoryLimit(); otherwise an Error
// "<where>: <what> needs about <estimate>, more than the <limit> this process may use (<source>)".
Result<void> checkMemory(uint64_t estimate_bytes, const std::string& where, const std::string& what);

}  // namespace drtv
