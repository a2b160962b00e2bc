// gltf_import.h — glTF for a world file's "gltf" entries (load.cpp): what loadGltf does, less the
// emissive point lights, which the world file makes once its instances are placed (world.h,
// emissiveLights). Private to drtv::worlds.
#pragma once

#include <filesystem>

#include "drtv/formats/error.h"
#include "drtv/worlds/world.h"

namespace drtv::worlds {

// loadGltf without emissiveLights(): meshes keep their emission, World::lights stays empty.
Result<World> loadGltfMeshes(const std::filesystem::path& path, InstanceClass cls);

}  // namespace drtv::worlds
