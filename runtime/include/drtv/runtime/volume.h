// drtv/runtime/volume.h — the three camera-following volume textures and the ambient lookup.
//
// References
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012, slides 33-36 (three
//      RGBA8 96x96x16 volumes following the camera, slab updates with wrap offsets, the frac trick
//      with clamp addressing and duplicated boundaries), slides 40-44 (the ambient shader),
//      slide 60 (the PC path's blur).
//  [2] Kaplanyan & Dachsbacher, "Cascaded Light Propagation Volumes", I3D 2010 (camera-snapped
//      volumes, seed 003).
//
// Texture layout. Three textures, one per colour channel (R, G, B); each texel is RGBA8 holding
// that channel's intensity for the bases B0..B3 (byte 0 = B0 ... byte 3 = B3, i.e. a uint32 with
// B0 in the low byte), times the volume's HDR scale / 255. Texel (x, y, z) of a texture is element
// x + size.x (y + size.y z) of its span. (The talk's slide code unswizzles textures that hold one
// basis colour each; its prose, and this project, hold one colour channel each: the same twelve
// numbers, and ambient becomes three dot products.)
//
// Toroidal addressing. The period N = size - 1 per axis: world texel g (centre at (g + 0.5) *
// texel_size) is stored at N-periodic index s = g mod N, independent of the camera, so a camera
// move rewrites only the slabs that entered. Physical texel N duplicates texel 0 on each axis, so
// that hardware trilinear filtering with clamp addressing is right across the wrap seam when the
// shader offsets the frac by half a texel (see VolumeShaderConstants). The volume covers world
// texels [origin, origin + N) with origin = floor(camera / texel_size) - N / 2.
//
// Defaults: 96x96x16 textures (the talk's size; 147,456 texels each) and 2 m x 2 m x 4 m texels:
//  - 2 m horizontally is half the index grid's 4 m cells, so every cell and sector boundary is a
//    texel boundary (no texel straddles two probes' cells) and 95 texels cover +-95 m, about one
//    and a half sectors around the camera;
//  - 4 m vertically spans +-30 m: terrain relief within the horizontal range (a 17 deg slope over
//    95 m) stays inside; 2 m layers would leave it at +-15 m and hand more to distant ambient.
//
// Thread-safety: a Volume is a plain value; const members may run concurrently with each other,
// never with a non-const member. PublishedVolume (publish.h) double-buffers it for readers.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/runtime/probe_cache.h"

namespace drtv::runtime {

enum class FillMode {
  kNearest,  // each texel takes the probe its index-grid cell names (the talk)
  kSmooth,   // each texel blends the probes of the 8 index-grid cells around it (trilinear weights)
};

struct VolumeOptions {
  glm::ivec3 size{96, 96, 16};             // texels per axis of each texture, >= 3; the toroidal
                                           // period is one less (the duplicated boundary)
  glm::vec3 texel_size_m{2.f, 2.f, 4.f};   // world metres per texel, > 0 (see the header)
  FillMode fill = FillMode::kNearest;
  bool blur = false;                       // 3x3x3 [1 2 1] blur of the texels (talk slide 60)
  // What the texels hold (representation.h); must equal the cache's. The fill, scroll and blur
  // move bytes and are the same for both (sh-l1's offset-binary bytes blend linearly).
  Representation representation = Representation::kFc3;
};

// What the shader needs (the talk's names, slide 40, plus the remap for the duplicated boundary):
//   ws       = (posWS - SnappedCamera) + normalWS * OffsetLength
//   volumeUV = frac(ws * UVScale + 0.5 + VolumeWrapOffset) * UVRemapScale + UVRemapBias
//   fetch_c  = tex3D(VolumeTexture_c, volumeUV) * HdrScale      (trilinear, clamp addressing)
struct VolumeShaderConstants {
  glm::dvec3 snapped_camera{0.0};   // world metres, the centre of the covered box
  glm::vec3 uv_scale{0.f};          // 1 / (period * texel size)
  glm::vec3 wrap_offset{0.f};       // frac((origin - 0.5) / period)
  glm::vec3 uv_remap_scale{0.f};    // period / size
  glm::vec3 uv_remap_bias{0.f};     // 0.5 / size
  float hdr_scale = 1.f;            // a texel byte v means v / 255 * hdr_scale
};

// The origin (world texel index of the first covered texel) that centres a volume with `options`
// on `camera` (world metres; clamped to +-1e8 m, non-finite reads as 0).
glm::ivec3 volumeOriginFor(const VolumeOptions& options, const glm::dvec3& camera);

class Volume {
 public:
  // Precondition: size >= 3 per axis, texel sizes finite and > 0 (bugs otherwise).
  explicit Volume(const VolumeOptions& options = {});

  const VolumeOptions& options() const { return options_; }
  glm::ivec3 size() const { return options_.size; }
  glm::ivec3 period() const { return options_.size - 1; }
  glm::ivec3 originFor(const glm::dvec3& camera) const { return volumeOriginFor(options_, camera); }
  bool built() const { return built_; }
  glm::ivec3 origin() const { return origin_; }

  // Fills every texel for `origin` from `cache` (its packed texels and scale).
  void rebuild(const glm::ivec3& origin, const ProbeCache& cache);
  // rebuild() spread over several calls (PublishedVolume's time-sliced refill). beginRebuild
  // fills every unblurred texel for `origin` from `cache`, the only read of the cache, so that
  // the texels are of one lighting state however many calls the refill takes; then it blurs the
  // first `blur_layers` layers (of period().z). advanceRebuild blurs up to `blur_layers` more.
  // built() once every layer is blurred; the texels then equal rebuild()'s bit for bit. Without
  // blur, beginRebuild completes the refill. Until built(), only these two may be called.
  void beginRebuild(const glm::ivec3& origin, const ProbeCache& cache, int blur_layers);
  void advanceRebuild(int blur_layers);
  // Moves to `origin`, filling only the texels that entered (and, with blur, re-blurring their
  // neighbours and the new faces). Rebuilds when not built, when a jump reaches a period, or
  // when the cache was packed with another scale. Afterwards the texels equal rebuild()'s bit
  // for bit.
  void scrollTo(const glm::ivec3& origin, const ProbeCache& cache);
  // Refills the texels inside sector `key`'s footprint (after it streamed in, was relit or left).
  void refillSector(SectorKey key, const ProbeCache& cache);
  // Refills the texels whose centres lie in the world box [lo, hi] (metres; z may be infinite),
  // widened as refillSector widens a sector (the smooth fill's reach, the blur's), and not beyond
  // the covered range. Afterwards those texels equal rebuild()'s, if the cache changed there only.
  void refillBox(const glm::dvec3& lo, const glm::dvec3& hi, const ProbeCache& cache);
  // The texels refillBox(lo, hi) would fill now (0 when not built): for choosing between refills
  // and a rebuild.
  uint64_t refillTexels(const glm::dvec3& lo, const glm::dvec3& hi) const;

  // RGBA8 texels of channel c (0 = R, 1 = G, 2 = B), layout as in the header.
  std::span<const uint32_t> texture(int channel) const { return texels_[channel]; }
  uint32_t physicalTexel(int channel, const glm::ivec3& p) const;
  // The texel world texel `g` maps to (precondition: g inside the covered range).
  uint32_t worldTexel(int channel, const glm::ivec3& g) const;
  float hdrScale() const { return scale_; }
  VolumeShaderConstants shaderConstants() const;
  // Texels computed so far (a counter for tests: a one-texel scroll computes one slab).
  uint64_t texelsFilled() const { return filled_; }
  // The memory the volume holds: its textures and, with blur, the unblurred copy the blur reads
  // (a quarter of the textures with the default 2 m texels, their size otherwise).
  size_t bytes() const {
    size_t n = 0;
    for (int c = 0; c < 3; ++c) n += (texels_[c].size() + source_[c].size()) * sizeof(uint32_t);
    return n;
  }

  // Where the volume's lookups are valid, in world texel units of the sample point p / texel
  // size - origin: [0.5, N - 0.5] per axis (beyond, the filter would mix the far side).
  // coverage() is 1 inside, fading linearly to 0 over `fade_texels` before that edge.
  float coverage(const glm::dvec3& position, float fade_texels) const;

 private:
  void fillBox(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache);
  void fillBoxSmooth(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache);
  // fillBox into the cell source (cell_source_): the cells of the texels of [g0, g1).
  void fillCells(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache);
  // Where the blur reads the unblurred texel of world column, row or layer g (axis a = 0, 1, 2):
  // the offset of its column, row or layer in source_[c] (its storage index, or its cell's).
  size_t sourceOffset(int a, int g) const;
  // sourceOffset for the apron's columns, rows and layers: world texels a0 + [0, a).
  void sourceOffsets(const glm::ivec3& a0, const glm::ivec3& a, std::vector<size_t>& xs, std::vector<size_t>& ys,
                     std::vector<size_t>& zs) const;
  void blurBox(glm::ivec3 g0, glm::ivec3 g1);
  void blurThinX(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a);
  void blurWholeRows(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a);
  void blurWholeRowsFromCells(const glm::ivec3& g0, const glm::ivec3& b, const glm::ivec3& a0, const glm::ivec3& a);
  // The duplicated boundary of the box just written into `tex` (one channel): physical index n
  // mirrors storage index 0 on each axis. xs, ys, zs: the box's storage indices per axis.
  void mirrorBoundary(uint32_t* tex, std::span<const int> xs, std::span<const int> ys, std::span<const int> zs) const;
  void writeRangeBox(const glm::ivec3& g0, const glm::ivec3& g1, const ProbeCache& cache);
  // refillBox's texel range [lo, hi) for a world box; false when empty.
  bool refillRange(const glm::dvec3& box_lo, const glm::dvec3& box_hi, glm::ivec3& lo, glm::ivec3& hi) const;
  size_t physicalIndex(const glm::ivec3& s) const { return size_t(s.x) + size_t(options_.size.x) * (size_t(s.y) + size_t(options_.size.y) * s.z); }

  VolumeOptions options_;
  bool built_ = false;
  glm::ivec3 origin_{0};
  float scale_ = 1.f;
  uint64_t filled_ = 0;
  int blurred_layers_ = 0;  // of a refill in progress (beginRebuild)
  std::array<std::vector<uint32_t>, 3> texels_;  // what the shader reads
  // The unblurred texels (only with blur). With the nearest fill and texels half an index cell
  // across (the default 2 m), each index cell's 2x2 texels of a layer are one probe's: source_
  // then holds one texel per cell (cell_source_), a quarter of the bytes to write on a refill, and
  // the blur's z and y passes run on cells (issue 38). Cell (cx, cy) of layer z is element
  // (cx mod P.x) + P.x ((cy mod P.y) + P.y (z mod N.z)), P = N / 2 + 2 per axis (in x rounded up
  // to a multiple of 8): more cells than a covered range spans (N / 2 + 1), so that cells are
  // stored independently of the camera, as texels are. Otherwise source_ is laid out as texels_.
  bool cell_source_ = false;
  glm::ivec3 source_stride_{0};  // elements between source columns, rows, layers
  glm::ivec2 cell_period_{0};    // P (with the cell source)
  std::array<std::vector<uint32_t>, 3> source_;
};

// The talk's ambient shader on the CPU [1, slides 40-44]: the volume sampled at the normal-offset
// position with trilinear filtering and the frac wrap, the basis weights with the down-basis wrap
// (sh::shadingWeights), ambient = sum_b w_b colour_b; for sh-l1 the bytes decoded as
// representation.h says and E(n) = max(0, e0 + e1 n.y + e2 n.z + e3 n.x) (shade()). Irradiance,
// linear RGB. `normal` is unit.
// Only meaningful where coverage() > 0. Thread-safe (const).
glm::vec3 sampleVolume(const Volume& volume, const glm::dvec3& position, const glm::vec3& normal, float normal_offset_m);

// sampleVolume with the 8 texels of the trilinear filter weighed by which side of the surface
// their centres lie on (the "normal-based" leak reduction of Unity's adaptive probe volumes): a
// texel whose centre is behind the plane through `position` with `normal` gets no weight, and the
// others share the filter's weight; if all 8 are behind, the plain filter. A roof's top then does
// not read the room under it through a 4 m texel that straddles the roof. Eight fetches per
// channel where the hardware filter does one; the shaders do not have it (an evaluation option,
// RuntimeOptions::volume_lookup). Thread-safe (const).
glm::vec3 sampleVolumeFacing(const Volume& volume, const glm::dvec3& position, const glm::vec3& normal, float normal_offset_m);

// sampleVolume with the texels behind the surface that lie on the other side of the sky line
// left out (issue 35): a texel's side is whether the probe its nearest fill took
// (ProbeCache::filledAt at its centre; with the volume's blur, before the blur) is covered (under
// static geometry: a room, a storey, an arcade) or open, and the point's side is that of the
// probe the index grid names at its offset sample. A texel behind the plane
// through `position` with `normal` and of the other side gets no weight; the others share the
// filter's; none left: the plain filter. A roof's top then reads the open probes above it, not
// the room under it through a 4 m texel that straddles the roof, and a ceiling the room, not the
// roof; on open ground (no covered probe near), and where the texels behind a surface are of its
// own side (the ground's, which repeat the cell over it), it is the plain filter. `cache` is the
// one the volume was filled from. Eight fetches and probe lookups per channel; the shaders do not
// have it (an evaluation option, RuntimeOptions::volume_lookup). Thread-safe (const).
glm::vec3 sampleVolumeSided(const Volume& volume, const ProbeCache& cache, const glm::dvec3& position, const glm::vec3& normal,
                            float normal_offset_m);

// The four colours the hardware would fetch at `position` (no normal offset), decoded (kFc3: basis
// intensities; kShL1: e0..e3): what sampleVolume shades. Exposed for tests and the query tool.
BasisColours fetchVolume(const Volume& volume, const glm::dvec3& position);

}  // namespace drtv::runtime
