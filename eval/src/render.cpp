// Preview renders. See render.h for the per-pixel model and the references [1]-[4].
#include "drtv/eval/render.h"
#include "drtv/eval/technique.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "drtv/eval/accuracy.h"
#include "drtv/reference/reference.h"
#include "drtv/formats/memory_limit.h"
#include "drtv/streamer/residency.h"
#include "render_support.h"
#include "drtv/baker/stopwatch.h"

namespace drtv::eval {
using namespace baker;
using namespace reference;
namespace {

using baker::detail::Clock;
using baker::detail::since;

// Reinhard's middle grey [3]: the log-average luminance is mapped here.
constexpr double kExposureKey = 0.18;
// Added to luminance before the log so that black pixels do not send the average to -inf [3].
constexpr double kLogDelta = 1e-4;
// The error image's relative error saturates at +-100%.
constexpr double kErrorRange = 1.0;
// A reference ambient below this fraction of the image's mean is treated as this (dark corners
// would otherwise show any absolute difference as a huge relative one).
constexpr double kErrorFloorFraction = 0.02;
// The blocks of the noise-robust error (RenderStats::block_*): squares of this many pixels a side,
// counted where at least half their pixels hit geometry. The reference's noise in a block's mean
// is its pixels' over sqrt(hits): 8x smaller in a full block of 8 x 8.
constexpr int kErrorBlockPixels = 8;
// Height of the error image's colour bar, pixels.
constexpr int kBarHeight = 8;

Result<glm::dvec3> parseTriple(std::string_view text) {
  std::istringstream s{std::string(text)};
  glm::dvec3 v;
  char c1 = 0, c2 = 0;
  if (!(s >> v.x >> c1 >> v.y >> c2 >> v.z) || c1 != ',' || c2 != ',' || !s.eof() || !std::isfinite(v.x) ||
      !std::isfinite(v.y) || !std::isfinite(v.z))
    return fail("bad triple");
  return v;
}

// Diverging blue - white - red for e in [-1, 1].
glm::u8vec3 diverging(double e) {
  e = std::clamp(e, -1.0, 1.0);
  const glm::dvec3 white(1.0), blue(0.12, 0.28, 0.85), red(0.85, 0.12, 0.1);
  const glm::dvec3 c = e < 0 ? glm::mix(white, blue, -e) : glm::mix(white, red, e);
  return glm::u8vec3(glm::clamp(c * 255.0 + 0.5, 0.0, 255.0));
}

float srgbEncode(float x) {
  x = std::clamp(x, 0.f, 1.f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.f / 2.4f) - 0.055f;
}

void put(image::RgbImage& img, size_t i, glm::u8vec3 c) {
  img.pixels[3 * i] = c.r, img.pixels[3 * i + 1] = c.g, img.pixels[3 * i + 2] = c.b;
}

}  // namespace

Result<RenderCamera> parseCamera(std::string_view text, RenderCamera camera) {
  auto bad = [&]() { return fail("--camera '" + std::string(text) + "': expected px,py,pz:tx,ty,tz[:fov_deg]"); };
  const size_t c1 = text.find(':');
  if (c1 == std::string_view::npos) return bad();
  const size_t c2 = text.find(':', c1 + 1);
  auto pos = parseTriple(text.substr(0, c1));
  auto tgt = parseTriple(text.substr(c1 + 1, c2 == std::string_view::npos ? std::string_view::npos : c2 - c1 - 1));
  if (!pos || !tgt) return bad();
  camera.position = *pos;
  camera.target = *tgt;
  if (c2 != std::string_view::npos) {
    std::istringstream s{std::string(text.substr(c2 + 1))};
    double fov = 0;
    if (!(s >> fov) || !s.eof()) return bad();
    camera.vertical_fov_deg = fov;
  }
  return camera;
}

glm::u8vec3 toneMap(const glm::vec3& radiance, float exposure) {
  glm::u8vec3 out;
  for (int c = 0; c < 3; ++c) {
    float x = radiance[c] * exposure;
    if (!std::isfinite(x) || x < 0.f) x = std::isinf(x) && x > 0.f ? 1e30f : 0.f;
    x = std::min(x, 1e30f);
    // ACES fit [2]: (x (a x + b)) / (x (c x + d) + e).
    const float y = (x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f);
    out[c] = uint8_t(std::lround(255.f * srgbEncode(y)));
  }
  return out;
}

Result<RenderResult> render(const worlds::World& world, const std::string& where, const Manifest& baked,
                            std::span<const Sector> sectors, const RenderOptions& options, const std::string& baked_where) {
  const std::string& archive = baked_where.empty() ? where : baked_where;
  const RenderCamera& cam = options.camera;
  if (cam.width < 1 || cam.height < 1 || cam.width > 8192 || cam.height > 8192)
    return fail("--size " + std::to_string(cam.width) + "x" + std::to_string(cam.height) + ": each side must be in [1, 8192]");
  const glm::dvec3 forward_d = cam.target - cam.position;
  if (!std::isfinite(glm::dot(forward_d, forward_d)) || !(glm::dot(forward_d, forward_d) > 0.0) ||
      !std::isfinite(glm::dot(cam.position, cam.position)))
    return fail("--camera: position and target must be finite and distinct");
  if (!(cam.vertical_fov_deg > 0.0 && cam.vertical_fov_deg < 170.0))
    return fail("--camera: field of view " + std::to_string(cam.vertical_fov_deg) + " deg must be in (0, 170)");
  if (!std::isfinite(options.hour)) return fail("--time: not a finite hour");
  if (options.reference_samples < 2) return fail("--samples " + std::to_string(options.reference_samples) + ": must be >= 2");
  if (auto why = validateLighting(baked.sky, baked.lights, baked.interiors); !why)
    return std::unexpected(why.error().context(archive + ": lighting"));
  {
    // Per pixel: the preview's buffers and images (~110 B); with the reference also its queries,
    // answers, error statistics and two more images (~400 B in all). 8192 x 8192 with the
    // reference is ~27 GB: refused up front where it cannot fit (memory_limit.h).
    const uint64_t pixels = uint64_t(cam.width) * uint64_t(cam.height);
    const uint64_t per_pixel = options.reference ? 400 : 110;
    const std::string size = std::to_string(cam.width) + "x" + std::to_string(cam.height);
    if (auto ok = checkMemory(pixels * per_pixel, archive + ": --size " + size,
                              std::string("a ") + size + (options.reference ? " render with its reference" : " render"));
        !ok)
      return std::unexpected(ok.error());
  }

  std::optional<tbb::global_control> limit;
  if (options.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(options.threads));

  ReferenceRegion region;
  region.camera_view = true;
  auto scene = ReferenceScene::build(world, where, region);
  if (!scene) return std::unexpected(scene.error());

  RenderResult out;
  const auto t_preview = Clock::now();
  // The technique, prepared from the sectors a streamer would hold around the camera.
  auto technique = makeTechnique(options.technique.empty() ? (options.smooth_fill ? "drtv-smooth" : "drtv-nearest") : options.technique,
                                 options.technique_params);
  if (!technique) return std::unexpected(technique.error());
  const SectorRange block = streamer::residentBlock(cam.position);
  std::vector<Sector> held;
  for (const Sector& s : sectors)
    if (block.contains(s.key)) held.push_back(s);
  if (auto r = (*technique)->prepareForArchive(baked, held, {world, where, block, options.seed, options.threads}); !r)
    return std::unexpected(r.error().context(archive));
  if (auto r = (*technique)->setLighting(options.hour, baked.lights); !r) return std::unexpected(r.error().context(archive));
  if (auto r = (*technique)->update(cam.position); !r) return std::unexpected(r.error().context(archive));
  const Technique& gi = **technique;
  out.stats.sectors_loaded = held.size();

  // Camera frame: Z up; looking straight up or down picks +Y as the image's up.
  const glm::dvec3 fwd = glm::normalize(forward_d);
  glm::dvec3 right = glm::cross(fwd, glm::dvec3(0, 0, 1));
  if (glm::dot(right, right) < 1e-12) right = glm::cross(fwd, glm::dvec3(0, 1, 0));
  right = glm::normalize(right);
  const glm::dvec3 up = glm::cross(right, fwd);
  const double tan_half = std::tan(cam.vertical_fov_deg * std::numbers::pi / 360.0);
  const double aspect = double(cam.width) / double(cam.height);
  const size_t n = size_t(cam.width) * size_t(cam.height);
  out.stats.pixels = n;

  const ReferenceLighting lighting{baked.sky, options.hour, baked.lights};
  const raytrace::RayScene& view = scene->viewRays();
  const glm::vec3 eye = scene->toLocal(cam.position);

  struct Pixel {
    glm::vec3 albedo{0.f}, direct{0.f}, sky{0.f};
  };
  std::vector<Pixel> px(n);
  out.preview_ambient.assign(n, glm::vec3(0.f));
  out.hit.assign(n, 0);
  std::vector<ReferenceQuery> queries(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) {
      const int x = int(i % size_t(cam.width)), y = int(i / size_t(cam.width));
      const double sx = (2.0 * (x + 0.5) / cam.width - 1.0) * tan_half * aspect;
      const double sy = (1.0 - 2.0 * (y + 0.5) / cam.height) * tan_half;
      const glm::vec3 dir = glm::vec3(glm::normalize(fwd + sx * right + sy * up));
      const raytrace::Hit h = view.intersect(raytrace::Ray{eye, 0.f, dir, std::numeric_limits<float>::infinity()});
      if (!h.hit()) {
        px[i].sky = baked.sky.skyRadiance(glm::dvec3(dir), options.hour);
        continue;
      }
      glm::vec3 nrm = view.normal(h.prim);
      if (glm::dot(nrm, dir) > 0.f) nrm = -nrm;  // seen from behind: shade the side in view
      const glm::dvec3 pos = scene->toWorld(eye + dir * h.t);
      out.hit[i] = 1;
      px[i].albedo = scene->viewAlbedo(h.prim);
      const DirectIrradiance d = directIrradiance(view, scene->origin(), lighting, pos, nrm);
      px[i].direct = d.sun + d.lights;
      out.preview_ambient[i] = gi.ambient(pos, nrm);
      queries[i] = {pos, nrm, uint64_t(i)};
    }
  });
  auto radiance = [&](size_t i, const glm::vec3& ambient) {
    return out.hit[i] ? px[i].albedo * float(1.0 / std::numbers::pi) * (ambient + px[i].direct) : px[i].sky;
  };
  out.stats.preview_s = since(t_preview);

  // Automatic exposure over the preview [3], over the pixels that are not black: black stays
  // black at any exposure, and a view half filled with a black surface (the palm-tree asset's
  // albedo-0 water) otherwise pulled the average down 100-fold and burnt the rest to white.
  double log_sum = 0;
  size_t lit = 0;
  for (size_t i = 0; i < n; ++i) {
    const double y = detail::luminance(radiance(i, out.preview_ambient[i]));
    if (!(y > 0.0)) continue;
    log_sum += std::log(kLogDelta + y);
    ++lit;
  }
  const double log_avg = lit ? std::exp(log_sum / double(lit)) : 1.0;
  out.stats.exposure = options.exposure > 0.f ? options.exposure : float(kExposureKey / std::max(log_avg, kLogDelta));
  if (!std::isfinite(out.stats.exposure)) out.stats.exposure = 1.f;

  out.preview = image::blankImage(cam.width, cam.height);
  for (size_t i = 0; i < n; ++i) put(out.preview, i, toneMap(radiance(i, out.preview_ambient[i]), out.stats.exposure));
  for (size_t i = 0; i < n; ++i) {
    if (!out.hit[i]) continue;
    ++out.stats.pixels_hit;
    out.stats.preview_mean_ambient += glm::dvec3(out.preview_ambient[i]);
  }
  if (out.stats.pixels_hit) out.stats.preview_mean_ambient /= double(out.stats.pixels_hit);
  out.stats.mean_abs_rel_error = out.stats.mean_rel_error = out.stats.reference_rel_std_error = std::nan("");
  out.stats.block_abs_rel_error = out.stats.block_rel_error = out.stats.block_reference_rel_std_error = std::nan("");
  if (!options.reference) return out;

  // The reference: path-trace only the pixels that hit geometry.
  const auto t_ref = Clock::now();
  std::vector<ReferenceQuery> hit_queries;
  std::vector<size_t> hit_index;
  for (size_t i = 0; i < n; ++i)
    if (out.hit[i]) hit_queries.push_back(queries[i]), hit_index.push_back(i);
  ReferenceSettings rs;
  rs.samples = options.reference_samples;
  rs.seed = options.seed;
  const std::vector<ReferenceIrradiance> ref = referenceIrradiance(*scene, lighting, hit_queries, rs, options.threads);
  out.stats.reference_s = since(t_ref);
  out.reference_ambient.assign(n, glm::vec3(0.f));
  std::vector<double> ref_std(n, 0.0);
  for (size_t k = 0; k < hit_index.size(); ++k) {
    out.reference_ambient[hit_index[k]] = ref[k].ambient.mean;
    ref_std[hit_index[k]] = detail::luminance(ref[k].ambient.std_error);
  }
  out.reference = image::blankImage(cam.width, cam.height);
  for (size_t i = 0; i < n; ++i) put(out.reference, i, toneMap(radiance(i, out.reference_ambient[i]), out.stats.exposure));

  // Error image and statistics.
  double ref_mean_lum = 0;
  for (size_t i : hit_index) {
    out.stats.reference_mean_ambient += glm::dvec3(out.reference_ambient[i]);
    ref_mean_lum += detail::luminance(out.reference_ambient[i]);
  }
  const double hits = std::max<double>(1.0, double(hit_index.size()));
  out.stats.reference_mean_ambient /= hits;
  ref_mean_lum /= hits;
  // The absolute floor too: a black reference (nothing to bounce from) must not divide by ~0.
  const double floor_lum = std::max(kAmbientErrorFloor, kErrorFloorFraction * ref_mean_lum);
  out.error = image::blankImage(cam.width, cam.height);
  for (size_t i : hit_index) {
    const double r = std::max(detail::luminance(out.reference_ambient[i]), floor_lum);
    put(out.error, i, diverging((detail::luminance(out.preview_ambient[i]) - detail::luminance(out.reference_ambient[i])) / r / kErrorRange));
  }
  const ErrorFigures pixels =
      errorFigures(out.preview_ambient, out.reference_ambient, ref_std, out.hit, cam.width, 1, floor_lum);
  out.stats.mean_abs_rel_error = pixels.abs_rel;
  out.stats.mean_rel_error = pixels.rel;
  out.stats.reference_rel_std_error = pixels.noise;
  const ErrorFigures blocks =
      errorFigures(out.preview_ambient, out.reference_ambient, ref_std, out.hit, cam.width, kErrorBlockPixels, floor_lum);
  out.stats.block_abs_rel_error = blocks.abs_rel;
  out.stats.block_rel_error = blocks.rel;
  out.stats.block_reference_rel_std_error = blocks.noise;
  out.stats.error_blocks = blocks.blocks;
  out.stats.block_pixels = kErrorBlockPixels;
  // Colour bar: -100% .. +100% across the width, ticks at -50%, 0, +50%.
  if (cam.height > 2 * kBarHeight)
    for (int y = cam.height - kBarHeight; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const double e = (2.0 * (x + 0.5) / cam.width - 1.0) * kErrorRange;
        glm::u8vec3 c = diverging(e / kErrorRange);
        for (double tick : {-0.5, 0.0, 0.5})
          if (std::abs(x - (tick / kErrorRange + 1.0) * 0.5 * cam.width) < 1.0 && y < cam.height - kBarHeight / 2) c = glm::u8vec3(0);
        put(out.error, size_t(y) * cam.width + x, c);
      }
  return out;
}

ErrorFigures errorFigures(std::span<const glm::vec3> preview, std::span<const glm::vec3> reference,
                          std::span<const double> reference_std, std::span<const uint8_t> hit, int width, int block,
                          double floor) {
  DRTV_CHECK(width > 0 && block > 0);
  DRTV_CHECK(preview.size() == reference.size() && reference.size() == reference_std.size() && hit.size() == preview.size());
  DRTV_CHECK(preview.size() % size_t(width) == 0);
  const int height = int(preview.size() / size_t(width));
  double abs_sum = 0, sum = 0, std_sum = 0;
  ErrorFigures out;
  for (int by = 0; by < height; by += block)
    for (int bx = 0; bx < width; bx += block) {
      double p = 0, r = 0, var = 0;
      int count = 0, area = 0;
      for (int y = by; y < std::min(height, by + block); ++y)
        for (int x = bx; x < std::min(width, bx + block); ++x) {
          const size_t i = size_t(y) * size_t(width) + size_t(x);
          ++area;
          if (!hit[i]) continue;
          ++count;
          p += detail::luminance(preview[i]);
          r += detail::luminance(reference[i]);
          var += reference_std[i] * reference_std[i];
        }
      if (count == 0 || 2 * count < area) continue;
      const double ref = std::max(r / count, floor);
      const double e = (p - r) / count / ref;
      abs_sum += std::abs(e);
      sum += e;
      std_sum += std::sqrt(var) / count / ref;
      ++out.blocks;
    }
  if (out.blocks) {
    out.abs_rel = abs_sum / double(out.blocks);
    out.rel = sum / double(out.blocks);
    out.noise = std_sum / double(out.blocks);
  }
  return out;
}

Result<RenderResult> render(const worlds::World& world, const std::string& where, const std::filesystem::path& archive,
                            const RenderOptions& options) {
  auto reader = ArchiveReader::open(archive);
  if (!reader) return std::unexpected(reader.error());
  std::vector<Sector> sectors;
  for (const SectorEntry& e : reader->manifest().sectors) {
    if (!streamer::residentBlock(options.camera.position).contains(e.key)) continue;
    auto s = reader->readSector(e.key);
    if (!s) return std::unexpected(s.error());
    sectors.push_back(std::move(*s));
  }
  return render(world, where, reader->manifest(), sectors, options, archive.string());
}

Result<std::vector<std::filesystem::path>> writeRenderImages(const RenderResult& result, const std::filesystem::path& path) {
  std::vector<std::filesystem::path> written;
  if (auto r = image::writePng(path, result.preview); !r) return std::unexpected(r.error());
  written.push_back(path);
  if (result.reference.width > 0) {
    const std::filesystem::path dir = path.parent_path(), stem = path.stem();
    const std::filesystem::path ref = dir / (stem.string() + "_reference.png"), err = dir / (stem.string() + "_error.png");
    if (auto r = image::writePng(ref, result.reference); !r) return std::unexpected(r.error());
    if (auto r = image::writePng(err, result.error); !r) return std::unexpected(r.error());
    written.push_back(ref);
    written.push_back(err);
  }
  return written;
}

}  // namespace drtv::eval
