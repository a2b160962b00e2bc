// Atomic writes of the files a farm's shards share (atomic_file.h).
#include "atomic_file.h"

#include <unistd.h>

#include <fstream>
#include <system_error>

namespace drtv::baker::detail {

std::string hostName() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

Result<void> writeFileAtomically(const std::filesystem::path& path, std::string_view bytes) {
  const std::filesystem::path tmp = path.string() + "." + hostName() + "." + std::to_string(::getpid()) + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) return fail(tmp.string() + ": cannot open for writing");
    f.write(bytes.data(), std::streamsize(bytes.size()));
    f.flush();
    if (!f) return fail(tmp.string() + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) return fail(path.string() + ": rename failed: " + ec.message());
  return {};
}

}  // namespace drtv::baker::detail
