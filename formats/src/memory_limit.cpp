#include "drtv/formats/memory_limit.h"

#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <tuple>

namespace drtv {
namespace {

std::atomic<uint64_t> g_limit_bytes{0};

// The process's current virtual size, resident size and data segment (bytes), from
// /proc/self/statm; 0 if unknown.
void currentUse(uint64_t& virtual_bytes, uint64_t& resident_bytes, uint64_t& data_bytes) {
  virtual_bytes = resident_bytes = data_bytes = 0;
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, resident = 0, shared = 0, text = 0, lib = 0, data = 0;
  if (!(statm >> size >> resident >> shared >> text >> lib >> data)) return;
  const auto page = uint64_t(::sysconf(_SC_PAGESIZE));
  virtual_bytes = size * page;
  resident_bytes = resident * page;
  data_bytes = data * page;
}

}  // namespace

uint64_t peakResidentBytes() {
  rusage usage{};
  if (::getrusage(RUSAGE_SELF, &usage) != 0 || usage.ru_maxrss <= 0) return 0;
  return uint64_t(usage.ru_maxrss) * 1024;  // Linux reports kilobytes
}

void setMemoryLimit(uint64_t bytes) { g_limit_bytes.store(bytes, std::memory_order_relaxed); }

MemoryLimit memoryLimit() {
  MemoryLimit m{UINT64_MAX, "no limit"};
  uint64_t used_virtual = 0, used_resident = 0, used_data = 0;
  currentUse(used_virtual, used_resident, used_data);
  // Physical memory less what this process already holds (other processes' share is not ours to
  // guess: they come and go; the kernel's OOM killer is the limit this avoids).
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  if (pages > 0 && page > 0) {
    const uint64_t physical = uint64_t(pages) * uint64_t(page);
    m = {physical > used_resident ? physical - used_resident : 0, "physical memory"};
  }
  for (auto [resource, name, used] : {std::tuple{RLIMIT_AS, "RLIMIT_AS", used_virtual}, std::tuple{RLIMIT_DATA, "RLIMIT_DATA", used_data}}) {
    rlimit r{};
    if (::getrlimit(resource, &r) != 0 || r.rlim_cur == RLIM_INFINITY) continue;
    const uint64_t left = uint64_t(r.rlim_cur) > used ? uint64_t(r.rlim_cur) - used : 0;
    if (left < m.bytes) m = {left, name};
  }
  // --max-memory bounds the whole process: what it already holds counts against it.
  const uint64_t set = g_limit_bytes.load(std::memory_order_relaxed);
  if (set > 0) {
    const uint64_t left = set > used_resident ? set - used_resident : 0;
    if (left < m.bytes) m = {left, "--max-memory"};
  }
  return m;
}

std::string formatBytes(uint64_t bytes) {
  char text[32];
  const double b = double(bytes);
  if (b >= 1e9) std::snprintf(text, sizeof text, "%.1f GB", b / 1e9);
  else if (b >= 1e6) std::snprintf(text, sizeof text, "%.0f MB", b / 1e6);
  else if (b >= 1e3) std::snprintf(text, sizeof text, "%.0f KB", b / 1e3);
  else std::snprintf(text, sizeof text, "%llu B", static_cast<unsigned long long>(bytes));
  return text;
}

std::optional<uint64_t> parseBytes(const std::string& text) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  std::string unit = text.substr(used);
  for (char& c : unit) c = char(std::toupper(static_cast<unsigned char>(c)));
  if (unit.size() == 2 && unit[1] == 'B') unit.resize(1);
  if (unit == "B") unit.clear();
  double scale = 1;
  if (unit == "K") scale = 1024.0;
  else if (unit == "M") scale = 1024.0 * 1024;
  else if (unit == "G") scale = 1024.0 * 1024 * 1024;
  else if (unit == "T") scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty()) return std::nullopt;
  const double bytes = v * scale;
  if (!std::isfinite(bytes) || !(bytes >= 1) || bytes > 1.8e19) return std::nullopt;
  return uint64_t(bytes);
}

Result<void> checkMemory(uint64_t estimate_bytes, const std::string& where, const std::string& what) {
  const MemoryLimit m = memoryLimit();
  if (estimate_bytes <= m.bytes) return {};
  return fail(where + ": " + what + " needs about " + formatBytes(estimate_bytes) + ", more than the " + formatBytes(m.bytes) +
              " this process may use (" + m.source + ")");
}

}  // namespace drtv
