// gltf.cpp — glTF 2.0 scenes as Worlds (see drtv/worlds/gltf.h).
//
// References:
//  [1] Khronos, glTF 2.0 specification 2.0.1 (2021): 3.5 nodes and transforms, 3.6 accessors
//      and byteStride, 3.7.2.1 primitive topologies, 3.9.2 base colour.
//  [2] KHR_draco_mesh_compression extension specification.
//  [3] IEC 61966-2-1 (sRGB transfer function).
//  [4] glTF 2.0 specification 2.0.1, 4.4 (GLB file format: header, JSON chunk, BIN chunk).
#include "drtv/worlds/gltf.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
// Must match tinygltf_impl.cpp: the TinyGLTF constructor refers to the image writer otherwise.
#define TINYGLTF_NO_STB_IMAGE_WRITE
#include <tiny_gltf.h>

#include "draco_mesh.h"
#include "gltf_container.h"
#include "gltf_import.h"
#include "drtv/formats/memory_limit.h"
#include "terrain.h"

namespace drtv::worlds {

std::vector<uint32_t> gltfStripToList(const std::vector<uint32_t>& strip) {
  std::vector<uint32_t> out;
  for (size_t i = 0; i + 2 < strip.size(); ++i) {
    const size_t odd = i % 2;
    out.insert(out.end(), {strip[i], strip[i + 1 + odd], strip[i + 2 - odd]});
  }
  return out;
}

std::vector<uint32_t> gltfFanToList(const std::vector<uint32_t>& fan) {
  std::vector<uint32_t> out;
  for (size_t i = 0; i + 2 < fan.size(); ++i) out.insert(out.end(), {fan[i + 1], fan[i + 2], fan[0]});
  return out;
}

namespace {

// Y-up -> Z-up: (x, y, z) -> (x, -z, y), a +90 deg rotation about X.
const glm::dmat4 kYupToZup(glm::dvec4(1, 0, 0, 0), glm::dvec4(0, 0, 1, 0), glm::dvec4(0, -1, 0, 0), glm::dvec4(0, 0, 0, 1));

glm::vec3 yUpToZup(glm::vec3 p) { return {p.x, -p.z, p.y}; }

// The peak a Draco decode adds, per count its bitstream declares (dracoDeclaredCounts) and per
// attribute the glTF maps, measured on Draco 1.5 with a counting operator new over grids of
// 180,000 triangles with 1-3 attributes, both encodings (docs/formats.md, "Value ranges and
// memory"): Draco's own arrays plus this loader's two copies of the positions and indices (24 B
// a face, 24 a point). An edgebreaker mesh's attribute seams add points beyond its declared
// vertices, up to 3 a face: hence its per-face cost per further attribute. On what was measured
// the estimate errs high by 3-51 %, never low.
constexpr uint64_t kDracoSequentialBytesPerFace = 48;               // 24 measured + the copies
constexpr uint64_t kDracoEdgebreakerBytesPerFace = 96;              // 68 measured (corner tables) + 24
constexpr uint64_t kDracoEdgebreakerBytesPerFacePerAttribute = 64;  // seams, from the second attribute on
constexpr uint64_t kDracoBytesPerPoint = 40;                        // the copies and the point map
constexpr uint64_t kDracoBytesPerPointAttribute = 24;   // 15-20 measured per attribute

float srgbToLinear(float c) {  // [3]
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

// Loader state for one file.
struct Loader {
  const tinygltf::Model& model;
  std::string file;  // file name for messages
  InstanceClass cls;
  World& world;
  GltfStats& stats;
  std::map<std::pair<int, int>, int> primitive_mesh;  // (mesh, primitive) -> drtv mesh or -1
  std::map<int, size_t> mesh_triangles_read;          // drtv mesh -> triangles before dropping
  size_t visits = 0;
  std::optional<Error> refused;  // the first input limit hit (a Draco mesh too large): ends the load

  void note(const std::string& what) { world.notes.push_back(what); }

  // Checked view of an accessor's elements: returns false (with `why`) when anything is out of
  // range. `element_size` is the byte size of one element.
  bool accessorSpan(int accessor_index, size_t element_size, const unsigned char*& first, size_t& stride,
                    size_t& count, std::string& why) const {
    if (accessor_index < 0 || size_t(accessor_index) >= model.accessors.size()) {
      why = "accessor " + std::to_string(accessor_index) + " does not exist";
      return false;
    }
    const tinygltf::Accessor& acc = model.accessors[size_t(accessor_index)];
    if (acc.sparse.isSparse) {
      why = "accessor " + std::to_string(accessor_index) + " is sparse (unsupported)";
      return false;
    }
    if (acc.bufferView < 0 || size_t(acc.bufferView) >= model.bufferViews.size()) {
      why = "accessor " + std::to_string(accessor_index) + ": bufferView " + std::to_string(acc.bufferView) + " does not exist";
      return false;
    }
    const tinygltf::BufferView& view = model.bufferViews[size_t(acc.bufferView)];
    if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size()) {
      why = "bufferView " + std::to_string(acc.bufferView) + ": buffer " + std::to_string(view.buffer) + " does not exist";
      return false;
    }
    const tinygltf::Buffer& buffer = model.buffers[size_t(view.buffer)];
    count = acc.count;
    stride = view.byteStride ? view.byteStride : element_size;
    if (stride < element_size) {
      why = "accessor " + std::to_string(accessor_index) + ": byteStride " + std::to_string(stride) + " < element size " + std::to_string(element_size);
      return false;
    }
    // Each bound is checked before the sum that relies on it, so nothing below can wrap: the view
    // lies in its buffer, the accessor's offset in its view, count <= 2^31 and stride <= 4096
    // (255 in valid files). A file-given offset added unchecked once wrapped to a pointer 16
    // bytes before the buffer (found by review beside fuzz_gltf).
    if (count > (size_t(1) << 31) || stride > 4096 || view.byteOffset > buffer.data.size() ||
        view.byteLength > buffer.data.size() - view.byteOffset) {
      why = "accessor " + std::to_string(accessor_index) + ": bufferView " + std::to_string(acc.bufferView) + " exceeds its buffer";
      return false;
    }
    if (acc.byteOffset > view.byteLength) {
      why = "accessor " + std::to_string(accessor_index) + ": byteOffset " + std::to_string(acc.byteOffset) +
            " lies past bufferView " + std::to_string(acc.bufferView);
      return false;
    }
    const size_t start = view.byteOffset + acc.byteOffset, room = view.byteLength - acc.byteOffset;
    if (count > 0 && stride * (count - 1) + element_size > room) {
      why = "accessor " + std::to_string(accessor_index) + ": " + std::to_string(count) + " elements exceed bufferView " + std::to_string(acc.bufferView);
      return false;
    }
    first = buffer.data.data() + start;
    return true;
  }

  // Decodes image `src`, stored in a bufferView, into `out` after checking the view against its
  // buffer; false when the view is bad or the bytes are no image stb_image reads.
  bool bufferViewImage(int src, tinygltf::Image& out) const {
    const tinygltf::Image& img = model.images[size_t(src)];
    if (size_t(img.bufferView) >= model.bufferViews.size()) return false;
    const tinygltf::BufferView& view = model.bufferViews[size_t(img.bufferView)];
    if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size()) return false;
    const std::vector<unsigned char>& data = model.buffers[size_t(view.buffer)].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset || view.byteLength > INT32_MAX)
      return false;
    std::string err, warn;
    out = img;
    const unsigned char* bytes = data.data() + view.byteOffset;
    if (stbImageRefusal(bytes, view.byteLength)) return false;
    return tinygltf::LoadImageData(&out, src, &err, &warn, 0, 0, bytes, int(view.byteLength), nullptr);
  }

  // Mean of a texture's texels: rgb sRGB-decoded when `srgb`, else linear; alpha always
  // linear (1 without an alpha channel); `coverage` = the fraction of texels whose alpha reaches
  // `cutoff`. Nothing when the material names no texture (or a texture without an image);
  // `decoded` false when the image is there but could not be read.
  struct TextureMean {
    glm::dvec4 mean{1.0};
    double coverage = 1.0;
    bool has_alpha = false;
    bool decoded = false;
    int image = -1;  // the image the texture names
  };
  std::optional<TextureMean> textureMean(int tex, bool srgb, double cutoff = 0.5) const {
    if (tex < 0 || size_t(tex) >= model.textures.size()) return std::nullopt;
    const int src = model.textures[size_t(tex)].source;
    if (src < 0 || size_t(src) >= model.images.size()) return std::nullopt;
    TextureMean out;
    out.image = src;
    tinygltf::Image from_view;
    const bool in_view = model.images[size_t(src)].bufferView >= 0 && bufferViewImage(src, from_view);
    const tinygltf::Image& img = in_view ? from_view : model.images[size_t(src)];
    const size_t texels = img.width > 0 && img.height > 0 ? size_t(img.width) * size_t(img.height) : 0;
    const size_t bytes_per_channel = img.bits == 16 ? 2 : img.bits == 8 ? 1 : 0;
    if (!texels || img.component < 1 || img.component > 4 || !bytes_per_channel ||
        img.image.size() < texels * size_t(img.component) * bytes_per_channel)
      return out;
    float lut[256];
    for (int i = 0; i < 256; ++i) lut[i] = srgb ? srgbToLinear(i / 255.f) : i / 255.f;
    auto read = [&](size_t t, int ch, bool colour) -> double {
      const size_t at = (t * size_t(img.component) + size_t(ch)) * bytes_per_channel;
      if (bytes_per_channel == 1) return colour ? lut[img.image[at]] : img.image[at] / 255.0;
      const float v = (img.image[at] | (img.image[at + 1] << 8)) / 65535.f;
      return colour && srgb ? srgbToLinear(v) : v;
    };
    // Grey images repeat channel 0; an alpha channel is the last of 2 or 4.
    const int alpha_ch = img.component == 2 ? 1 : img.component == 4 ? 3 : -1;
    out.has_alpha = alpha_ch >= 0;
    glm::dvec4 sum(0.0);
    size_t covered = 0;
    for (size_t t = 0; t < texels; ++t) {
      for (int c = 0; c < 3; ++c) sum[c] += read(t, img.component >= 3 ? c : 0, true);
      const double a = alpha_ch >= 0 ? read(t, alpha_ch, false) : 1.0;
      sum[3] += a;
      covered += a >= cutoff;
    }
    out.mean = sum / double(texels);
    out.coverage = double(covered) / double(texels);
    out.decoded = true;
    return out;
  }

  // What the bake and the path tracer take from a material (gltf.h, docs/world-format.md
  // "Materials"): diffuse albedo, emission, double-sidedness, or why its primitives are left out.
  struct MaterialInfo {
    glm::vec3 albedo{1.f};
    glm::vec3 emission{0.f};
    bool double_sided = false;
    std::string skip_why;  // non-empty: the primitives with this material are skipped
  };
  std::map<int, MaterialInfo> material_info;

  static std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
  }

  const MaterialInfo& materialOf(int material_index) {
    if (auto it = material_info.find(material_index); it != material_info.end()) return it->second;
    MaterialCounts& counts = world.materials;
    ++counts.materials;
    MaterialInfo info;
    // No material: white, non-metallic, opaque (drtv's convention for bare geometry; the spec's
    // default material, metallic 1, would be black to a diffuse-only renderer).
    if (material_index < 0 || size_t(material_index) >= model.materials.size()) {
      ++counts.opaque;
      return material_info[material_index] = info;
    }
    const tinygltf::Material& mat = model.materials[size_t(material_index)];
    const std::string label = "material '" + (mat.name.empty() ? std::to_string(material_index) : mat.name) + "'";
    const std::string what = file + ": " + label;
    const auto& pbr = mat.pbrMetallicRoughness;
    const auto& f = pbr.baseColorFactor;
    glm::dvec4 base(1.0);
    for (size_t c = 0; c < 4 && c < f.size(); ++c) base[int(c)] = f[c];
    const double cutoff = mat.alphaMode == "MASK" ? mat.alphaCutoff : 0.5;
    const auto base_tex = textureMean(pbr.baseColorTexture.index, true, cutoff / std::max(base.a, 1e-9));
    if (base_tex && !base_tex->decoded)
      note("ignored: " + file + ": image " + std::to_string(base_tex->image) + " not decoded; albedo from baseColorFactor only");
    glm::dvec3 albedo(base);
    double alpha = base.a;
    if (base_tex && base_tex->decoded) {
      albedo *= glm::dvec3(base_tex->mean);
      alpha *= base_tex->mean.a;
    }
    // Metallic [1, 3.9.2]: a metal has no diffuse lobe; drtv's surfaces are diffuse only.
    double metallic = std::clamp(std::isfinite(pbr.metallicFactor) ? pbr.metallicFactor : 1.0, 0.0, 1.0);
    if (const auto mr = textureMean(pbr.metallicRoughnessTexture.index, false); mr && mr->decoded)
      metallic *= mr->mean.b;  // metalness is the blue channel, linear
    if (metallic > 0.0) {
      ++counts.metallic;
      albedo *= 1.0 - metallic;
      note("material: " + what + ": metallic " + num(metallic) + ": diffuse albedo = base colour x " + num(1.0 - metallic));
    }
    // Emission [1, 3.9.3] x KHR_materials_emissive_strength.
    glm::dvec3 le(0.0);
    for (size_t c = 0; c < 3 && c < mat.emissiveFactor.size(); ++c) le[int(c)] = mat.emissiveFactor[c];
    if (const auto et = textureMean(mat.emissiveTexture.index, true); et) {
      if (et->decoded) le *= glm::dvec3(et->mean);
      else note("ignored: " + what + ": emissive texture not decoded; emission from emissiveFactor only");
    }
    double strength = 1.0;
    if (const auto ext = mat.extensions.find("KHR_materials_emissive_strength"); ext != mat.extensions.end()) {
      if (ext->second.Has("emissiveStrength") && ext->second.Get("emissiveStrength").IsNumber())
        strength = ext->second.Get("emissiveStrength").GetNumberAsDouble();
      if (!(std::isfinite(strength) && strength >= 0.0)) {
        note("ignored: " + what + ": KHR_materials_emissive_strength " + num(strength) + " (must be finite and >= 0)");
        strength = 1.0;
      }
    }
    le *= strength;
    for (int c = 0; c < 3; ++c) le[c] = std::isfinite(le[c]) ? std::clamp(le[c], 0.0, double(kMaxColourValue)) : 0.0;
    if (le.r > 0.0 || le.g > 0.0 || le.b > 0.0) {
      ++counts.emissive;
      info.emission = glm::vec3(le);
      albedo = glm::dvec3(0.0);
      note("material: " + what + ": emissive, Le (" + num(le.r) + ", " + num(le.g) + ", " + num(le.b) +
           ") W/m^2/sr from its front faces: point lights (see 'emissive:'); albedo 0");
    }
    if (mat.doubleSided) ++counts.double_sided;
    info.double_sided = mat.doubleSided;
    // Alpha [1, 3.9.4]: drtv's surfaces are opaque; each primitive is kept whole or left out.
    if (mat.alphaMode == "MASK") {
      if (base.a < mat.alphaCutoff) {
        ++counts.mask_skipped;
        info.skip_why = label + ": alphaMode MASK, baseColorFactor alpha " + num(base.a) +
                        " < alphaCutoff " + num(mat.alphaCutoff) + ": cut away whole";
      } else {
        ++counts.mask_kept;
        std::string tex;
        if (base_tex && base_tex->decoded && base_tex->has_alpha)
          tex = "; its texture's alpha is not applied (" + num(100.0 * base_tex->coverage) + " % of texels reach the cutoff)";
        note("material: " + what + ": alphaMode MASK, baseColorFactor alpha " + num(base.a) + " >= alphaCutoff " +
             num(mat.alphaCutoff) + ": opaque" + tex);
      }
    } else if (mat.alphaMode == "BLEND") {
      if (alpha < 0.5) {
        ++counts.blend_skipped;
        info.skip_why = label + ": alphaMode BLEND, mean alpha " + num(alpha) + " < 0.5: left out";
      } else {
        ++counts.blend_kept;
        note("material: " + what + ": alphaMode BLEND, mean alpha " + num(alpha) + " >= 0.5: opaque");
      }
    } else {
      ++counts.opaque;
    }
    for (int c = 0; c < 3; ++c) {
      info.albedo[c] = std::isfinite(albedo[c]) ? float(std::clamp(albedo[c], 0.0, 1.0)) : 0.5f;
    }
    return material_info[material_index] = info;
  }

  // Builds the drtv mesh for one primitive, or returns -1 (with a note) when skipped.
  int primitiveMesh(int mesh_index, int prim_index) {
    if (refused) return -1;
    const auto key = std::make_pair(mesh_index, prim_index);
    if (auto it = primitive_mesh.find(key); it != primitive_mesh.end()) return it->second;
    const int result = buildPrimitive(mesh_index, prim_index);
    primitive_mesh[key] = result;
    return result;
  }

  // Decodes a KHR_draco_mesh_compression extension object [2] into Z-up positions and a
  // triangle list; false (with `why`) when the object, its bufferView or the bitstream is bad.
  // Before Draco allocates for the counts its bitstream declares, the peak is estimated
  // (kDracoBytesPer*); beyond what the process may use, `refused` names the file and the key.
  bool dracoPrimitive(const tinygltf::Value& ext, const std::string& key, std::vector<glm::vec3>& positions,
                      std::vector<uint32_t>& indices, std::string& why) {
    const tinygltf::Value& view_value = ext.Get("bufferView");
    const tinygltf::Value& position_value = ext.Get("attributes").Get("POSITION");
    if (!view_value.IsInt()) return why = "no integer bufferView", false;
    if (!position_value.IsInt()) return why = "no integer attributes.POSITION", false;
    const int view_index = view_value.GetNumberAsInt();
    if (view_index < 0 || size_t(view_index) >= model.bufferViews.size())
      return why = "bufferView " + std::to_string(view_index) + " does not exist", false;
    const tinygltf::BufferView& view = model.bufferViews[size_t(view_index)];
    if (view.buffer < 0 || size_t(view.buffer) >= model.buffers.size())
      return why = "bufferView " + std::to_string(view_index) + ": buffer " + std::to_string(view.buffer) + " does not exist", false;
    const std::vector<unsigned char>& data = model.buffers[size_t(view.buffer)].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
      return why = "bufferView " + std::to_string(view_index) + " exceeds its buffer", false;
    char error[160];
    DracoDeclared declared;
    if (!dracoDeclaredCounts(data.data() + view.byteOffset, view.byteLength, &declared, error, sizeof error))
      return why = error, false;
    const uint64_t attributes = std::max<uint64_t>(1, ext.Get("attributes").Keys().size());
    const uint64_t per_face = declared.edgebreaker
                                  ? kDracoEdgebreakerBytesPerFace + kDracoEdgebreakerBytesPerFacePerAttribute * (attributes - 1)
                                  : kDracoSequentialBytesPerFace;
    const uint64_t estimate = declared.faces * per_face + declared.points * (kDracoBytesPerPoint + kDracoBytesPerPointAttribute * attributes);
    if (auto ok = checkMemory(estimate, file + ": key '" + key + "'",
                              "a Draco mesh of " + std::to_string(declared.faces) + " triangles and " +
                                  std::to_string(declared.points) + " points");
        !ok) {
      refused = ok.error();
      return why = ok.error().message, false;
    }
    DracoMesh mesh;
    if (!decodeDracoMesh(data.data() + view.byteOffset, view.byteLength, position_value.GetNumberAsInt(), &mesh, error,
                         sizeof error))
      return why = error, false;
    positions.resize(mesh.vertex_count);
    for (size_t v = 0; v < mesh.vertex_count; ++v)
      positions[v] = yUpToZup(glm::vec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]));
    indices.assign(mesh.indices, mesh.indices + mesh.index_count);
    freeDracoMesh(&mesh);
    return true;
  }

  // Positions (Z-up) and triangle-list indices of a primitive stored in plain accessors; false
  // (with `why`) when an accessor is missing, out of its buffer or an index out of range.
  bool accessorPrimitive(const tinygltf::Primitive& prim, int pos_acc, std::vector<glm::vec3>& positions,
                         std::vector<uint32_t>& indices, std::string& why) const {
    auto fail_with = [&](std::string reason) {
      why = std::move(reason);
      return false;
    };
    const unsigned char* pos_data = nullptr;
    size_t pos_stride = 0, vertex_count = 0;
    if (!accessorSpan(pos_acc, 12, pos_data, pos_stride, vertex_count, why)) return fail_with("POSITION " + why);
    positions.resize(vertex_count);
    for (size_t v = 0; v < vertex_count; ++v) {
      glm::vec3 p;
      std::memcpy(&p, pos_data + v * pos_stride, 12);
      positions[v] = yUpToZup(p);
    }

    if (prim.indices >= 0) {
      if (size_t(prim.indices) >= model.accessors.size()) return fail_with("indices accessor does not exist");
      const tinygltf::Accessor& ia = model.accessors[size_t(prim.indices)];
      size_t size = 0;
      switch (ia.componentType) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: size = 1; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: size = 2; break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: size = 4; break;
        default: return fail_with("indices component type " + std::to_string(ia.componentType) + " is not u8/u16/u32");
      }
      if (ia.type != TINYGLTF_TYPE_SCALAR) return fail_with("indices are not SCALAR");
      const unsigned char* idx_data = nullptr;
      size_t idx_stride = 0, idx_count = 0;
      if (!accessorSpan(prim.indices, size, idx_data, idx_stride, idx_count, why)) return fail_with("indices " + why);
      indices.resize(idx_count);
      for (size_t i = 0; i < idx_count; ++i) {
        const unsigned char* at = idx_data + i * idx_stride;
        uint32_t value = 0;
        if (size == 1) value = at[0];
        else if (size == 2) { uint16_t v; std::memcpy(&v, at, 2); value = v; }
        else std::memcpy(&value, at, 4);
        if (value >= vertex_count)
          return fail_with("index " + std::to_string(value) + " at " + std::to_string(i) + " out of range (" +
                           std::to_string(vertex_count) + " vertices)");
        indices[i] = value;
      }
    } else {
      indices.resize(vertex_count);
      for (size_t v = 0; v < vertex_count; ++v) indices[v] = uint32_t(v);
    }
    if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) indices = gltfStripToList(indices);
    else if (prim.mode == TINYGLTF_MODE_TRIANGLE_FAN) indices = gltfFanToList(indices);
    return true;
  }

  int buildPrimitive(int mesh_index, int prim_index) {
    const tinygltf::Mesh& gm = model.meshes[size_t(mesh_index)];
    const tinygltf::Primitive& prim = gm.primitives[size_t(prim_index)];
    const std::string what = file + ": mesh '" + (gm.name.empty() ? std::to_string(mesh_index) : gm.name) +
                             "' primitive " + std::to_string(prim_index);
    auto skip = [&](const std::string& why) {
      note("skipped: " + what + ": " + why);
      ++stats.primitives_skipped;
      return -1;
    };
    if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      static const char* kModeNames[] = {"points", "lines", "line loop", "line strip"};
      return skip("mode " + std::to_string(prim.mode) + " (" +
                  (prim.mode >= 0 && prim.mode <= 3 ? kModeNames[prim.mode] : "unknown") + ") is not triangles");
    }
    const MaterialInfo& material = materialOf(prim.material);
    if (!material.skip_why.empty()) return skip(material.skip_why);
    const auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) return skip("no POSITION attribute");
    const int pos_acc = pos_it->second;
    if (pos_acc < 0 || size_t(pos_acc) >= model.accessors.size()) return skip("POSITION accessor does not exist");
    const tinygltf::Accessor& pa = model.accessors[size_t(pos_acc)];
    if (pa.type != TINYGLTF_TYPE_VEC3 || pa.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
      return skip("POSITION is not VEC3 of FLOAT");
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    std::string why;
    if (const auto draco = prim.extensions.find("KHR_draco_mesh_compression"); draco != prim.extensions.end()) {
      // [2]: the positions and the triangle list come from the Draco bitstream, not from the
      // accessors' bufferViews (which a Draco file leaves out); it is a list whatever the mode.
      const std::string key = "meshes[" + std::to_string(mesh_index) + "].primitives[" + std::to_string(prim_index) +
                              "].extensions.KHR_draco_mesh_compression";
      if (!dracoPrimitive(draco->second, key, positions, indices, why)) {
        if (refused) return -1;
        return skip("KHR_draco_mesh_compression: " + why);
      }
    } else if (!accessorPrimitive(prim, pos_acc, positions, indices, why)) {
      return skip(why);
    }
    const size_t vertex_count = positions.size();
    if (indices.size() % 3 != 0) {
      note("ignored: " + what + ": " + std::to_string(indices.size() % 3) + " trailing indices");
      indices.resize(indices.size() - indices.size() % 3);
    }

    // Keep only finite, non-degenerate triangles; then keep only the vertices they use.
    Mesh mesh;
    mesh.name = what;
    mesh.albedo = material.albedo;
    mesh.emission = material.emission;
    mesh.double_sided = material.double_sided;
    std::vector<uint32_t> remap(vertex_count, UINT32_MAX);
    size_t nonfinite = 0, degenerate = 0;
    const size_t tri_count = indices.size() / 3;
    stats.triangles_read += tri_count;
    for (size_t t = 0; t < tri_count; ++t) {
      const uint32_t* tri = &indices[3 * t];
      const glm::vec3 a = positions[tri[0]], b = positions[tri[1]], c = positions[tri[2]];
      if (!std::isfinite(a.x + a.y + a.z + b.x + b.y + b.z + c.x + c.y + c.z)) { ++nonfinite; continue; }
      const glm::vec3 n = glm::cross(b - a, c - a);
      const float area2 = glm::dot(n, n);
      if (!(area2 > 0.f) || !std::isfinite(area2)) { ++degenerate; continue; }
      for (int k = 0; k < 3; ++k) {
        uint32_t& r = remap[tri[k]];
        if (r == UINT32_MAX) {
          r = uint32_t(mesh.positions.size());
          mesh.positions.push_back(positions[tri[k]]);
        }
        mesh.indices.push_back(r);
      }
    }
    stats.dropped_nonfinite += nonfinite;
    stats.dropped_degenerate += degenerate;
    if (nonfinite) note("dropped: " + what + ": " + std::to_string(nonfinite) + " triangles with NaN/Inf positions");
    if (degenerate) note("dropped: " + what + ": " + std::to_string(degenerate) + " zero-area triangles");
    if (mesh.indices.empty()) return skip("no triangles left");
    ++stats.primitives_loaded;
    world.meshes.push_back(std::move(mesh));
    mesh_triangles_read[int(world.meshes.size() - 1)] = tri_count;
    return int(world.meshes.size() - 1);
  }

  // Local matrix of a node (column-major, glTF space), or false when it is not finite.
  static bool localMatrix(const tinygltf::Node& node, glm::dmat4& m) {
    if (node.matrix.size() == 16) {
      m = glm::make_mat4(node.matrix.data());
    } else {
      glm::dmat4 t(1.0), r(1.0), s(1.0);
      if (node.translation.size() == 3) t = glm::translate(glm::dmat4(1.0), glm::make_vec3(node.translation.data()));
      if (node.rotation.size() == 4) {
        const glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);  // w, x, y, z
        const double len = glm::length(q);
        r = glm::mat4_cast(len > 0 ? q / len : glm::dquat(1, 0, 0, 0));
      }
      if (node.scale.size() == 3) s = glm::scale(glm::dmat4(1.0), glm::make_vec3(node.scale.data()));
      m = t * r * s;
    }
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 4; ++k)
        if (!std::isfinite(m[c][k])) return false;
    return true;
  }

  // A node on the walk's stack: its world matrix and the next of its children to enter.
  struct Frame {
    int node;
    glm::dmat4 world;
    size_t next_child;
  };

  // Adds node `node_index`'s instances under `parent` and pushes it onto `stack`, or notes why it
  // is skipped (missing, a cycle, past the visit bound, a non-finite transform).
  void enter(int node_index, const glm::dmat4& parent, std::vector<bool>& on_path, std::vector<Frame>& stack) {
    if (node_index < 0 || size_t(node_index) >= model.nodes.size()) {
      note("skipped: " + file + ": node " + std::to_string(node_index) + " does not exist");
      return;
    }
    if (on_path[size_t(node_index)]) {
      ++stats.cycles_skipped;
      note("skipped: " + file + ": node " + std::to_string(node_index) + " is its own ancestor (cycle)");
      return;
    }
    // glTF nodes form a forest, so each is visited once; a file that shares children between
    // parents could blow up exponentially: stop at a generous bound.
    if (++visits > 4 * model.nodes.size() + 1024) {
      if (visits == 4 * model.nodes.size() + 1025) note("skipped: " + file + ": node graph is not a forest; traversal stopped");
      return;
    }
    const tinygltf::Node& node = model.nodes[size_t(node_index)];
    glm::dmat4 local;
    if (!localMatrix(node, local)) {
      note("skipped: " + file + ": node " + std::to_string(node_index) + " has a non-finite transform");
      return;
    }
    const glm::dmat4 m = parent * local;
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= model.meshes.size()) {
        note("skipped: " + file + ": node " + std::to_string(node_index) + ": mesh " + std::to_string(node.mesh) + " does not exist");
      } else {
        const glm::dmat4 to_world = kYupToZup * m * glm::transpose(kYupToZup);  // C M C^-1, C orthonormal
        const auto& prims = model.meshes[size_t(node.mesh)].primitives;
        for (size_t p = 0; p < prims.size(); ++p) {
          const int mesh = primitiveMesh(node.mesh, int(p));
          if (mesh < 0) continue;
          Instance inst;
          inst.mesh = uint32_t(mesh);
          stats.instanced_triangles_read += mesh_triangles_read[mesh];
          stats.instanced_triangles_kept += world.meshes[size_t(mesh)].triangleCount();
          inst.transform = to_world;
          inst.cls = cls;
          inst.name = file + ": node " + (node.name.empty() ? std::to_string(node_index) : "'" + node.name + "'");
          world.instances.push_back(std::move(inst));
        }
      }
    }
    on_path[size_t(node_index)] = true;
    stack.push_back(Frame{node_index, m, 0});
  }

  // Depth-first, parents before children, from `root`. An explicit stack, not recursion: a
  // hierarchy may be as deep as the file has nodes (a chain of 3,000 overflowed the stack of the
  // recursive walk this replaces, under ASan).
  void visit(int root, std::vector<bool>& on_path) {
    std::vector<Frame> stack;
    enter(root, glm::dmat4(1.0), on_path, stack);
    while (!stack.empty()) {
      Frame& top = stack.back();
      const std::vector<int>& children = model.nodes[size_t(top.node)].children;
      if (top.next_child < children.size()) {
        const int child = children[top.next_child++];
        const glm::dmat4 parent = top.world;  // `top` dies if enter() grows the stack
        enter(child, parent, on_path, stack);
      } else {
        on_path[size_t(top.node)] = false;
        stack.pop_back();
      }
    }
  }

  void run() {
    std::vector<int> roots;
    int scene = model.defaultScene;
    if (scene < 0 && !model.scenes.empty()) scene = 0;
    if (scene >= 0 && size_t(scene) < model.scenes.size()) {
      roots = model.scenes[size_t(scene)].nodes;
    } else {
      std::vector<bool> is_child(model.nodes.size(), false);
      for (const auto& n : model.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < is_child.size()) is_child[size_t(c)] = true;
      for (size_t i = 0; i < model.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(int(i));
      note("note: " + file + ": no scene; loaded " + std::to_string(roots.size()) + " root nodes");
    }
    std::vector<bool> on_path(model.nodes.size(), false);
    for (int r : roots) visit(r, on_path);
  }
};

// Decodes images with tinygltf's stb_image loader but never fails the file over a texture:
// the texture only refines the albedo.
// An image stored in a bufferView is left undecoded here: tinygltf 2.7 hands it over as
// &buffer.data[byteOffset] with byteLength bytes, never checked against the buffer (a fuzzed GLB
// made stb_image read 2 KB past its end). Loader::bufferViewImage decodes it once checked.
bool lenientImageLoader(tinygltf::Image* image, const int image_idx, std::string* err, std::string* warn, int req_w,
                        int req_h, const unsigned char* bytes, int size, void* user) {
  if (image->bufferView >= 0) {
    image->image.clear();
    return true;
  }
  std::string local_err;
  if (const char* why = stbImageRefusal(bytes, size_t(std::max(size, 0)))) {
    if (warn) *warn += "image " + std::to_string(image_idx) + " not decoded: " + why + "\n";
    image->image.clear();
    return true;
  }
  if (tinygltf::LoadImageData(image, image_idx, &local_err, warn, req_w, req_h, bytes, size, user)) return true;
  if (warn) *warn += "image " + std::to_string(image_idx) + " not decoded: " + local_err + "\n";
  image->image.clear();
  return true;
}

std::string oneLine(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  std::replace(s.begin(), s.end(), '\n', ';');
  return s;
}

// Parses `bytes` as GLB (binary) or glTF JSON and builds the World; `file` names it in messages.
Result<World> loadGltfBytes(std::span<const uint8_t> bytes, bool binary, const std::string& file, const std::string& world_name,
                            const std::filesystem::path& base_dir, InstanceClass cls, GltfStats* stats_out,
                            bool make_lights) {
  // tinygltf takes the size as unsigned int.
  if (bytes.size() > UINT32_MAX) return fail(file + ": " + std::to_string(bytes.size()) + " bytes, more than glTF's 4 GiB");
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(lenientImageLoader, nullptr);
  std::string err, warn;
  bool ok = false;
  const std::string base = base_dir.string();
  {
    // The JSON: all of a .gltf; a .glb's first chunk [4], when its header says where (if it does
    // not, tinygltf reports the container as broken).
    std::string_view json_text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    size_t json_at = 0;
    if (binary) {
      uint32_t json_bytes = 0;
      if (bytes.size() >= 20) std::memcpy(&json_bytes, bytes.data() + 12, 4);
      json_at = 20;
      json_text = bytes.size() >= 20 && json_bytes <= bytes.size() - 20 ? json_text.substr(20, json_bytes) : std::string_view();
    }
    if (const size_t deep = jsonTooDeepAt(json_text); deep != std::string_view::npos)
      return fail(file + ": byte " + std::to_string(json_at + deep) + ": JSON nested deeper than " +
                  std::to_string(kMaxJsonDepth) + " levels");
  }
  try {
    if (binary) {
      if (const std::string bad = glbBinChunkError(bytes); !bad.empty()) return fail(file + ": " + bad);
      const auto rewritten = glbWithoutDracoIndices(bytes);
      const std::span<const uint8_t> glb = rewritten ? std::span<const uint8_t>(*rewritten) : bytes;
      DRTV_CHECK(glbBinChunkError(glb).empty());  // the rewrite moves the chunks, never their bounds
      if (glb.size() > UINT32_MAX) return fail(file + ": more than glTF's 4 GiB");
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn, glb.data(), unsigned(glb.size()), base);
    } else {
      const std::string_view original(reinterpret_cast<const char*>(bytes.data()), bytes.size());
      const auto rewritten = withoutDracoIndices(original);
      const std::string_view text = rewritten ? std::string_view(*rewritten) : original;
      if (text.size() > UINT32_MAX) return fail(file + ": more than glTF's 4 GiB");
      ok = loader.LoadASCIIFromString(&model, &err, &warn, text.data(), unsigned(text.size()), base);
    }
  } catch (const std::exception& e) {  // tinygltf's JSON parser may throw on malformed input
    return fail(file + ": glTF parse error: " + e.what());
  }
  if (!ok) return fail(file + ": glTF error: " + oneLine(err.empty() ? std::string("tinygltf failed without a message") : err));

  World world;
  world.name = world_name;
  GltfStats stats;
  if (!warn.empty()) world.notes.push_back("warning: " + file + ": " + oneLine(warn));
  for (const std::string& e : model.extensionsRequired)
    if (e != "KHR_draco_mesh_compression" && e != "KHR_materials_pbrSpecularGlossiness" && e != "KHR_texture_transform" &&
        e != "KHR_materials_emissive_strength")
      world.notes.push_back("warning: " + file + ": required extension " + e + " is not supported; loaded without it");
  Loader l{model, file, cls, world, stats, {}, {}, 0, std::nullopt, {}};
  l.run();
  if (l.refused) return std::unexpected(*l.refused);
  if (world.materials.double_sided > 0)
    world.notes.push_back("material: " + file + ": " + std::to_string(world.materials.double_sided) + " of " +
                          std::to_string(world.materials.materials) +
                          " materials double-sided: a surface from both sides in the bake and the path tracer (a "
                          "single-sided one's back faces read as the inside of geometry)");
  if (make_lights) emissiveLights(world);
  world.effects = defaultEffects(world);
  if (stats_out) *stats_out = stats;
  return world;
}

}  // namespace

namespace {
Result<World> loadGltfFile(const std::filesystem::path& path, InstanceClass cls, GltfStats* stats_out, bool make_lights) {
  const std::string file = path.string();
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext != ".gltf" && ext != ".glb") return fail(file + ": not a .gltf or .glb file");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return fail(file + ": no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(file + ": cannot open");
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return fail(file + ": read error");
  return loadGltfBytes(bytes, ext == ".glb", file, path.filename().string(), path.parent_path(), cls, stats_out, make_lights);
}
}  // namespace

Result<World> loadGltf(const std::filesystem::path& path, InstanceClass cls, GltfStats* stats_out) {
  return loadGltfFile(path, cls, stats_out, true);
}

Result<World> loadGltfMeshes(const std::filesystem::path& path, InstanceClass cls) {
  return loadGltfFile(path, cls, nullptr, false);
}

Result<World> loadGltfFromMemory(std::span<const uint8_t> bytes, const std::string& name,
                                 const std::filesystem::path& base_dir, InstanceClass cls, GltfStats* stats) {
  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  return loadGltfBytes(bytes, binary, name, name, base_dir, cls, stats, true);
}

}  // namespace drtv::worlds
