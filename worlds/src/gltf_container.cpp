// gltf_container.cpp — the checks and rewrites of a glTF file's bytes before tinygltf parses
// them (gltf_container.h).
#include "gltf_container.h"

#include <cstring>

#include <nlohmann/json.hpp>

namespace drtv::worlds {

size_t jsonTooDeepAt(std::string_view text) {
  int depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth) return i;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return std::string_view::npos;
}

std::optional<std::string> withoutDracoIndices(std::string_view text) {
  if (text.find("KHR_draco_mesh_compression") == std::string_view::npos) return std::nullopt;
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return std::nullopt;
  bool changed = false;
  const auto meshes = doc.find("meshes");
  if (meshes == doc.end() || !meshes->is_array()) return std::nullopt;
  for (auto& mesh : *meshes) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
    for (auto& prim : mesh["primitives"]) {
      if (!prim.is_object() || !prim.contains("indices")) continue;
      const auto ext = prim.find("extensions");
      if (ext != prim.end() && ext->is_object() && ext->contains("KHR_draco_mesh_compression")) {
        prim.erase("indices");
        changed = true;
      }
    }
  }
  if (!changed) return std::nullopt;
  return doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::optional<std::vector<uint8_t>> glbWithoutDracoIndices(std::span<const uint8_t> glb) {
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, glb.data() + at, 4);
    return v;
  };
  constexpr uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
  // Only a container whose declared length fits the bytes and holds the JSON chunk: the rewrite
  // keeps that length's relation to the chunks (it once wrote the true size instead, which made a
  // truncated GLB look whole to tinygltf, found by fuzz_gltf).
  if (glb.size() < 20 || u32(16) != kJsonChunk || u32(8) < 20 || u32(8) > glb.size() || u32(12) > u32(8) - 20)
    return std::nullopt;
  const size_t json_bytes = u32(12);
  auto text = withoutDracoIndices(std::string_view(reinterpret_cast<const char*>(glb.data() + 20), json_bytes));
  if (!text) return std::nullopt;
  while (text->size() % 4) text->push_back(' ');
  if (text->size() > UINT32_MAX - (u32(8) - json_bytes)) return std::nullopt;
  std::vector<uint8_t> out(glb.begin(), glb.begin() + 12);
  const uint32_t chunk = uint32_t(text->size()), total = uint32_t(u32(8) - json_bytes + text->size());
  std::memcpy(out.data() + 8, &total, 4);
  out.resize(20);
  std::memcpy(out.data() + 12, &chunk, 4);
  std::memcpy(out.data() + 16, &kJsonChunk, 4);
  out.insert(out.end(), text->begin(), text->end());
  out.insert(out.end(), glb.begin() + 20 + std::ptrdiff_t(json_bytes), glb.end());
  return out;
}

std::string glbBinChunkError(std::span<const uint8_t> glb) {
  if (glb.size() < 20) return "";
  uint32_t length, json_bytes;
  std::memcpy(&length, glb.data() + 8, 4);
  std::memcpy(&json_bytes, glb.data() + 12, 4);
  const uint64_t bin_at = 20ull + json_bytes;
  if (length > glb.size() || bin_at + 8 > length) return "";  // tinygltf refuses these itself
  uint32_t bin_bytes;
  std::memcpy(&bin_bytes, glb.data() + bin_at, 4);
  if (bin_at + 8 + bin_bytes <= length) return "";
  return "byte " + std::to_string(bin_at) + ": BIN chunk of " + std::to_string(bin_bytes) + " bytes runs past the " +
         std::to_string(length) + "-byte GLB";
}

}  // namespace drtv::worlds
