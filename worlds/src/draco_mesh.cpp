// draco_mesh.cpp — Draco's decoder behind the plain-data interface of draco_mesh.h.
//
// References:
//  [1] KHR_draco_mesh_compression extension specification (Khronos, 2019): the bufferView holds
//      one Draco bitstream; attributes map glTF semantics to Draco unique ids.
//  [2] Draco 1.5 decoder API: Decoder::DecodeMeshFromBuffer, PointAttribute::mapped_index.
//
// Nothing here may include drtv's other headers (error.h needs std::expected, which the fuzz
// tree compiles only against libc++): see draco_mesh.h for why this file stands apart.
#include "draco_mesh.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>

#include <draco/compression/config/compression_shared.h>
#include <draco/compression/decode.h>
#include <draco/compression/point_cloud/point_cloud_decoder.h>
#include <draco/core/varint_decoding.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>
#include <draco/metadata/metadata_decoder.h>

namespace drtv::worlds {
namespace {

bool failWith(char* error, size_t error_size, const char* what, long long a = -1, long long b = -1) {
  if (error && error_size) {
    if (a < 0) std::snprintf(error, error_size, "%s", what);
    else if (b < 0) std::snprintf(error, error_size, "%s %lld", what, a);
    else std::snprintf(error, error_size, "%s %lld (of %lld)", what, a, b);
  }
  return false;
}

bool decode(const unsigned char* bytes, size_t size, int position_id, DracoMesh* out, char* error, size_t error_size) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes), size);
  const auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
  if (!type.ok()) return failWith(error, error_size, "not a Draco bitstream");
  if (type.value() != draco::TRIANGULAR_MESH) return failWith(error, error_size, "Draco bitstream is not a triangle mesh");
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok()) return failWith(error, error_size, "Draco decoding failed");
  const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  if (!mesh) return failWith(error, error_size, "Draco decoding returned no mesh");
  if (position_id < 0) return failWith(error, error_size, "POSITION attribute id is negative:", position_id);
  const draco::PointAttribute* pos = mesh->GetAttributeByUniqueId(uint32_t(position_id));
  if (!pos) return failWith(error, error_size, "no Draco attribute with unique id", position_id);
  if (pos->num_components() < 1) return failWith(error, error_size, "POSITION attribute has no components");

  const size_t points = mesh->num_points();
  const size_t faces = mesh->num_faces();
  if (!pos->is_mapping_identity() && pos->indices_map_size() < points)
    return failWith(error, error_size, "POSITION point map shorter than the point count", static_cast<long long>(pos->indices_map_size()), static_cast<long long>(points));
  // Both counts come from a bitstream that Draco has already decoded into memory of that size,
  // so the products below cannot exceed what is allocated already; check anyway (no overflow).
  if (points > SIZE_MAX / (3 * sizeof(float)) || faces > SIZE_MAX / (3 * sizeof(uint32_t)))
    return failWith(error, error_size, "Draco mesh too large");
  DracoMesh m;
  m.vertex_count = points;
  m.index_count = faces * 3;
  m.positions = static_cast<float*>(std::malloc(points ? points * 3 * sizeof(float) : 1));
  m.indices = static_cast<uint32_t*>(std::malloc(faces ? faces * 3 * sizeof(uint32_t) : 1));
  if (!m.positions || !m.indices) {
    freeDracoMesh(&m);
    return failWith(error, error_size, "out of memory for the decoded Draco mesh");
  }
  for (draco::PointIndex p(0); p < uint32_t(points); ++p) {
    const draco::AttributeValueIndex v = pos->mapped_index(p);
    if (v.value() >= pos->size()) {
      freeDracoMesh(&m);
      return failWith(error, error_size, "POSITION value index out of range at point", static_cast<long long>(p.value()));
    }
    if (!pos->ConvertValue<float>(v, 3, m.positions + 3 * size_t(p.value()))) {
      freeDracoMesh(&m);
      return failWith(error, error_size, "POSITION value not convertible to float at point", static_cast<long long>(p.value()));
    }
  }
  for (draco::FaceIndex f(0); f < uint32_t(faces); ++f) {
    const draco::Mesh::Face& face = mesh->face(f);
    for (int k = 0; k < 3; ++k) {
      const uint32_t index = face[k].value();
      if (index >= points) {
        freeDracoMesh(&m);
        return failWith(error, error_size, "Draco face index out of range at face", static_cast<long long>(f.value()), static_cast<long long>(faces));
      }
      m.indices[3 * size_t(f.value()) + size_t(k)] = index;
    }
  }
  *out = m;
  return true;
}

// A count as the bitstream of version `version` stores it: uint32 before `varint_from`, varint
// from it on (Draco 1.5's MeshSequentialDecoder and MeshEdgeBreakerDecoderImpl).
bool readCount(draco::DecoderBuffer& buffer, uint16_t version, uint16_t varint_from, uint32_t* out) {
  if (version < varint_from) return buffer.Decode(out);
  return draco::DecodeVarint(out, &buffer);
}

bool declared(const unsigned char* bytes, size_t size, DracoDeclared* out, char* error, size_t error_size) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes), size);
  draco::DracoHeader header;
  if (!draco::PointCloudDecoder::DecodeHeader(&buffer, &header).ok()) return failWith(error, error_size, "not a Draco bitstream");
  if (header.encoder_type != draco::TRIANGULAR_MESH) return failWith(error, error_size, "Draco bitstream is not a triangle mesh");
  if (header.version_major < 1 || header.version_major > draco::kDracoMeshBitstreamVersionMajor ||
      (header.version_major == draco::kDracoMeshBitstreamVersionMajor && header.version_minor > draco::kDracoMeshBitstreamVersionMinor))
    return failWith(error, error_size, "unknown Draco bitstream version", header.version_major);
  const uint16_t version = DRACO_BITSTREAM_VERSION(header.version_major, header.version_minor);
  buffer.set_bitstream_version(version);
  if (version >= DRACO_BITSTREAM_VERSION(1, 3) && (header.flags & METADATA_FLAG_MASK)) {
    // Entries are read one by one and each is bounded by the bytes left, as in the decoder.
    draco::GeometryMetadata metadata;
    draco::MetadataDecoder metadata_decoder;
    if (!metadata_decoder.DecodeGeometryMetadata(&buffer, &metadata)) return failWith(error, error_size, "Draco metadata unreadable");
  }
  uint32_t faces = 0, points = 0;
  if (header.encoder_method == draco::MESH_SEQUENTIAL_ENCODING) {
    if (!readCount(buffer, version, DRACO_BITSTREAM_VERSION(2, 2), &faces) ||
        !readCount(buffer, version, DRACO_BITSTREAM_VERSION(2, 2), &points))
      return failWith(error, error_size, "Draco sequential connectivity header truncated");
    out->faces = faces;
    out->points = points;
    out->edgebreaker = false;
    return true;
  }
  if (header.encoder_method != draco::MESH_EDGEBREAKER_ENCODING)
    return failWith(error, error_size, "unknown Draco mesh encoding method", header.encoder_method);
  uint8_t traversal = 0;
  if (!buffer.Decode(&traversal)) return failWith(error, error_size, "Draco edgebreaker header truncated");
  uint32_t new_vertices = 0, encoded_vertices = 0, symbols = 0, split_symbols = 0;
  uint8_t attribute_data = 0;
  const uint16_t v20 = DRACO_BITSTREAM_VERSION(2, 0);
  if (version < DRACO_BITSTREAM_VERSION(2, 2) && !readCount(buffer, version, v20, &new_vertices))
    return failWith(error, error_size, "Draco edgebreaker header truncated");
  if (!readCount(buffer, version, v20, &encoded_vertices) || !readCount(buffer, version, v20, &faces) ||
      !buffer.Decode(&attribute_data) || !readCount(buffer, version, v20, &symbols) ||
      !readCount(buffer, version, v20, &split_symbols))
    return failWith(error, error_size, "Draco edgebreaker header truncated");
  out->faces = faces;
  out->points = uint64_t(encoded_vertices) + split_symbols + new_vertices;
  out->edgebreaker = true;
  return true;
}

}  // namespace

bool dracoDeclaredCounts(const unsigned char* bytes, size_t size, DracoDeclared* out, char* error,
                         size_t error_size) noexcept {
  *out = DracoDeclared{};
  if (error && error_size) error[0] = '\0';
  try {
    return declared(bytes, size, out, error, error_size);
  } catch (const std::exception& e) {  // std::bad_alloc from the metadata's strings
    return failWith(error, error_size, e.what());
  } catch (...) {
    return failWith(error, error_size, "Draco threw an unknown exception");
  }
}

bool decodeDracoMesh(const unsigned char* bytes, size_t size, int position_id, DracoMesh* out, char* error,
                     size_t error_size) noexcept {
  *out = DracoMesh{};
  if (error && error_size) error[0] = '\0';
  try {
    return decode(bytes, size, position_id, out, error, error_size);
  } catch (const std::exception& e) {  // std::bad_alloc from Draco's containers
    return failWith(error, error_size, e.what());
  } catch (...) {
    return failWith(error, error_size, "Draco threw an unknown exception");
  }
}

void freeDracoMesh(DracoMesh* mesh) noexcept {
  std::free(mesh->positions);
  std::free(mesh->indices);
  *mesh = DracoMesh{};
}

}  // namespace drtv::worlds
