// atomic_file.h — files that the shards of one bake write beside each other on a farm (the
// folder's stamp, each shard's status): a write goes to a temporary file of its own, named by host
// and process, and is renamed over the target, so two writers never share a temporary (one
// shard's rename would take the file another is still writing) and a reader never sees half a
// file. Private to baker/src.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "drtv/formats/error.h"

namespace drtv::baker::detail {

// This machine's name (gethostname), "unknown" when it has none.
std::string hostName();

// Writes `bytes` to `path` through "<path>.<host>.<pid>.tmp" and a rename. Errors name the file
// that could not be written or renamed. Thread-safe for distinct paths; processes may race on one
// path, and the last rename wins whole.
Result<void> writeFileAtomically(const std::filesystem::path& path, std::string_view bytes);

}  // namespace drtv::baker::detail
