// tinygltf_impl.cpp — the one translation unit that compiles tinygltf and stb_image.
//
// Without TINYGLTF_ENABLE_DRACO: tinygltf 2.7's Draco path trusts every index in the file (it
// read out of bounds on fuzzed input), so gltf.cpp decodes KHR_draco_mesh_compression itself,
// with checks, through draco_mesh.h. stb_image is compiled static
// (STB_IMAGE_STATIC) so that its symbols cannot clash with another library's copy; the
// heightmap loader reaches it through decodeImage16() below.
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#include <tiny_gltf.h>  // includes <stb_image.h> with its implementation

#include <cstring>

#include "terrain.h"

namespace drtv::worlds {

bool peekImageSize(const unsigned char* bytes, size_t size, int& width, int& height, int& channels) {
  if (size > size_t(INT32_MAX)) return false;
  return stbi_info_from_memory(bytes, int(size), &width, &height, &channels) != 0;
}

const char* stbImageRefusal(const unsigned char* bytes, size_t size) {
  static const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size < 8 || std::memcmp(bytes, kPngSignature, 8) != 0) return nullptr;
  // PNG chunks: u32 big-endian length, 4-byte type, data, u32 CRC (PNG spec, 5.3).
  for (size_t at = 8; at + 8 <= size;) {
    const uint32_t length = uint32_t(bytes[at]) << 24 | uint32_t(bytes[at + 1]) << 16 | uint32_t(bytes[at + 2]) << 8 | bytes[at + 3];
    if (length == 0 && std::memcmp(bytes + at + 4, "IDAT", 4) == 0) return "PNG with an empty IDAT chunk";
    // A chunk longer than what follows it: stb_image would first grow its IDAT buffer to the
    // declared length (a 4.7 KB file made it allocate 2 GiB: fuzz_gltf, second long run).
    if (length > size - at - 8 || size - at - 8 - length < 4) return "PNG chunk longer than the file";
    at += 12 + size_t(length);
  }
  return nullptr;
}

bool decodeImage16(const unsigned char* bytes, size_t size, int& width, int& height, int& channels,
                   std::vector<uint16_t>& pixels, std::string& error) {
  if (const char* why = stbImageRefusal(bytes, size)) {
    error = why;
    return false;
  }
  if (size > size_t(INT32_MAX)) {
    error = "file too large";
    return false;
  }
  stbi_us* data = stbi_load_16_from_memory(bytes, int(size), &width, &height, &channels, 0);
  if (!data) {
    const char* reason = stbi_failure_reason();
    error = reason ? reason : "unknown stb_image failure";
    return false;
  }
  pixels.assign(data, data + size_t(width) * height * channels);
  stbi_image_free(data);
  return true;
}

}  // namespace drtv::worlds
