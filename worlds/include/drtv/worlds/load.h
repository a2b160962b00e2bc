// drtv/worlds/load.h — loading a World from a file: JSON world files and glTF/GLB scenes.
//
// The JSON world format is documented in docs/world-format.md. Every error message starts with
// the file name and, for JSON, names the offending key by its full dotted path, e.g.
// "worlds/x.json: key 'primitives[2].albedo': expected array of 3 numbers".
// Thread-safety: the functions may run concurrently.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

// Loads `path` by extension: ".json" -> parseWorldJson on the file's text (relative paths in it
// are relative to the file's folder); ".gltf"/".glb" -> loadGltf as one static world with the
// default sky and defaultEffects. Anything else, an unreadable file or bad content is an Error
// whose message starts with the path.
Result<World> loadWorld(const std::filesystem::path& path);

// Parses a JSON world file's text. `base_dir` resolves relative paths inside it (glTF files,
// heightmaps); `file_name` prefixes every error message. Effects absent -> defaultEffects()
// and effects_explicit = false.
Result<World> parseWorldJson(std::string_view text, const std::filesystem::path& base_dir,
                             const std::string& file_name);

}  // namespace drtv::worlds
