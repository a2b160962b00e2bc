// drtv/baker/render.h — CPU preview renders of a baked world: what the engine would show (the
// probes' ambient through the runtime's volume, plus direct sun and point lights with shadow
// rays), its path-traced counterpart and a false-colour image of the difference. `drtv render`.
//
//  [1] Gilabert & Stefanov, "Deferred Radiance Transfer Volumes", GDC 2012: slides 37-44 (a
//      G-buffer of position, normal and albedo; the ambient buffer from the volumes; then the sun
//      and the dynamic lights), slides 7-9 (the test box this is first used on).
//  [2] Narkowicz, "ACES Filmic Tone Mapping Curve", 2016 (the fitted ACES curve used here).
//  [3] Reinhard et al., "Photographic Tone Reproduction for Digital Images", SIGGRAPH 2002 (the
//      log-average "key" behind the automatic exposure).
//  [4] IEC 61966-2-1 (sRGB transfer function).
//
// Per pixel (both images share everything but the ambient):
//   primary ray (Embree, static + dynamic triangles) -> position, normal (turned to face the
//   camera), albedo rho;  radiance = rho / pi * (ambient + E_sun + E_lights);  a miss shows the sky.
//   E_sun, E_lights: reference.h's directIrradiance against the camera view, so dynamic objects
//   cast direct shadows (the engine's shadow maps would), identically in both images.
//   preview ambient:   runtime::Runtime::ambient() with the sectors a streamer would hold around
//                      the camera (streamer::residentBlock, 49 <= 51) and the volume centred on it;
//   reference ambient: reference.h's path-traced ambient (sun and sky bounce, direct sky, local
//                      lights) with `reference_samples` paths per pixel, keyed by pixel index.
// Error image: the relative error of the ambient's luminance, (preview - reference) / reference,
// blue (preview too dark) - white (equal) - red (too bright), saturating at +-100%; pixels that
// see the sky are black; a colour bar along the bottom marks -100%, -50%, 0, +50%, +100%.
// Tone mapping: exposure (automatic: key 0.18 over the preview's log-average luminance [3]),
// the ACES fit [2], sRGB [4]; the same exposure for both images so that they compare.
//
// Thread-safety: render() uses all TBB threads (or `threads`); the result does not depend on
// their number.
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/formats/sector.h"
#include "drtv/image/image.h"
#include "drtv/worlds/world.h"

namespace drtv::eval {

struct RenderCamera {
  glm::dvec3 position{0.0, -30.0, 8.0};  // world metres
  glm::dvec3 target{0.0, 0.0, 1.5};      // world point at the image centre (Z is up)
  double vertical_fov_deg = 50.0;        // (0, 170)
  int width = 480, height = 270;         // pixels, each in [1, 8192]
};

// Parses "px,py,pz:tx,ty,tz" or "px,py,pz:tx,ty,tz:fov_deg" into `camera` (size untouched).
// Errors name the text: "--camera '1,2:3': expected px,py,pz:tx,ty,tz[:fov_deg]".
Result<RenderCamera> parseCamera(std::string_view text, RenderCamera camera = {});

struct RenderOptions {
  RenderCamera camera;
  double hour = 9.0;            // time of day, any finite real (modulo 24)
  bool reference = false;       // also path-trace the reference and the error image
  int reference_samples = 64;   // paths per pixel of the reference ambient (>= 2)
  uint64_t seed = 1;            // keys the reference's random numbers
  float exposure = 0.f;         // radiance multiplier before tone mapping; 0 = automatic
  bool smooth_fill = false;     // the runtime's smooth volume fill instead of nearest probe
  // The registered technique that shades the preview (technique.h), prepared from the archive's
  // sectors; "" = drtv-nearest (drtv-smooth with smooth_fill).
  std::string technique;
  std::map<std::string, std::string> technique_params;
  int threads = 0;              // 0 = all hardware threads
};

struct RenderStats {
  size_t sectors_loaded = 0;    // sectors made resident in the runtime
  size_t pixels = 0, pixels_hit = 0;
  float exposure = 1.f;         // the exposure used
  double preview_s = 0;         // wall seconds: primary rays, ambient, direct light
  double reference_s = 0;       // wall seconds of the path tracing (0 without reference)
  // Over pixels that hit geometry (reference only; NaN otherwise). Luminance of the ambient.
  double mean_abs_rel_error = 0;   // mean |preview - reference| / reference
  double mean_rel_error = 0;       // mean (preview - reference) / reference: the bias
  double reference_rel_std_error = 0;  // mean standard error / reference: the noise floor
  // The same three over blocks of 8 x 8 pixels (those at least half hit), each block's mean
  // luminance against the reference's: per pixel, a reference's noise inflates the mean |error|
  // (a perfect engine reads about 0.8 x the noise) and the bias (E[1 / X] > 1 / E[X]: about the
  // noise squared); a block's mean has an eighth of it. What the engine gets wrong over areas
  // (a wall, a floor) shows in both; per-pixel detail (edges, contact shadows) only in the pixels'.
  double block_abs_rel_error = 0, block_rel_error = 0, block_reference_rel_std_error = 0;
  size_t error_blocks = 0;             // blocks counted
  int block_pixels = 0;                // their side, pixels (8)
  glm::dvec3 preview_mean_ambient{0.0}, reference_mean_ambient{0.0};  // RGB means
};

// Mean |relative error|, bias and the reference's noise (RenderStats' figures) of the ambient
// `preview` against `reference` (per pixel, row-major, `width` pixels a row; `reference_std` the
// standard error of each reference pixel's luminance), over the pixels `hit`, in squares of
// `block` x `block` pixels (1: per pixel): a square counts where at least half its pixels hit, and
// compares the mean luminance of those pixels, divided by at least `floor` (> 0). NaN with no
// square counted. Preconditions (bugs): spans of one size, a multiple of width; width, block > 0.
struct ErrorFigures {
  double abs_rel = std::nan(""), rel = std::nan(""), noise = std::nan("");
  size_t blocks = 0;  // squares counted
};
ErrorFigures errorFigures(std::span<const glm::vec3> preview, std::span<const glm::vec3> reference,
                          std::span<const double> reference_std, std::span<const uint8_t> hit, int width, int block,
                          double floor);

struct RenderResult {
  image::RgbImage preview;     // always
  image::RgbImage reference;   // with RenderOptions::reference
  image::RgbImage error;       // with RenderOptions::reference
  // Per pixel, row-major from the top-left: ambient irradiance (linear RGB; 0 where the sky is
  // seen) of the preview and the reference, and whether the pixel hit geometry.
  std::vector<glm::vec3> preview_ambient, reference_ambient;
  std::vector<uint8_t> hit;
  RenderStats stats;
};

// Renders `world` (geometry) lit as `baked` says (sky, lights, interiors, effects: the archive's
// manifest; its sector list is ignored) with probes from `sectors` (all of a bake, or those near
// the camera: streamer::residentBlock, the 7 x 7 block around it, is made resident). `where` prefixes errors.
// Errors: bad camera (non-finite, position == target, looking straight up or down is fine),
// bad size, unsound lighting, geometry errors (reference.h), runtime errors (a sector rejected).
// Errors in the baked data (lighting, sectors) name `baked_where` (the archive), or `where` when
// it is empty.
Result<RenderResult> render(const worlds::World& world, const std::string& where, const Manifest& baked,
                            std::span<const Sector> sectors, const RenderOptions& options, const std::string& baked_where = {});

// The same from an archive: reads the sectors around the camera from it. Errors name the archive.
Result<RenderResult> render(const worlds::World& world, const std::string& where, const std::filesystem::path& archive,
                            const RenderOptions& options);

// Linear RGB radiance -> 8-bit sRGB with `exposure`, the ACES fit and the sRGB curve. Pure.
glm::u8vec3 toneMap(const glm::vec3& radiance, float exposure);

// Writes `result`'s images: the preview at `path`, and with a reference "<stem>_reference.png"
// and "<stem>_error.png" beside it. Returns the paths written.
Result<std::vector<std::filesystem::path>> writeRenderImages(const RenderResult& result, const std::filesystem::path& path);

}  // namespace drtv::eval
