// drtv render <archive> --world <world.json> --camera px,py,pz:tx,ty,tz[:fov] --time HH:MM
//             -o img.png [--size WxH] [--reference] [--samples N] [--exposure X] [--smooth]
// A CPU preview of the baked ambient plus direct light; with --reference also the path-traced
// image and a false-colour error image (render.h). Statistics go to <stem>.json beside the PNG.
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "commands.h"
#include "drtv/eval/render.h"
#include "drtv/eval/technique.h"
#include "drtv/worlds/load.h"

namespace drtv::app {
namespace {

struct RenderCliOptions {
  std::string archive, world, camera = "0,-30,8:0,0,1.5", size = "480x270", time = "09:00", output = "render.png";
  std::string technique, params;
  bool reference = false, smooth = false;
  int samples = 64, threads = 0;
  float exposure = 0.f;
  uint64_t seed = 1;
};

Result<std::pair<int, int>> parseSize(const std::string& text) {
  int w = 0, h = 0;
  char x = 0;
  std::istringstream s(text);
  if (!(s >> w >> x >> h) || x != 'x' || !s.eof() || w < 1 || h < 1 || w > 8192 || h > 8192)
    return fail("--size '" + text + "': expected WxH, each in [1, 8192]");
  return std::pair{w, h};
}

nlohmann::json rgb(const glm::dvec3& v) { return {v.r, v.g, v.b}; }

// The image's path: a name without an extension gets ".png" (`-o /tmp/palm` writes /tmp/palm.png
// beside /tmp/palm_reference.png, not a PNG named /tmp/palm); any other extension than .png is
// refused before the render, not written as PNG bytes under a name that says otherwise.
Result<std::string> imagePath(const std::string& output) {
  std::filesystem::path p(output);
  if (p.filename().empty() || p.filename() == "." || p.filename() == "..")
    return fail("-o '" + output + "': expected an image file's name, e.g. render.png");
  if (!p.has_extension()) return p.string() + ".png";
  std::string ext = p.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png") return fail("-o '" + output + "': drtv render writes PNG images; name the file .png");
  return output;
}

Result<void> run(RenderCliOptions o) {
  auto image = imagePath(o.output);
  if (!image) return std::unexpected(image.error());
  o.output = *image;
  eval::RenderOptions opts;
  auto size = parseSize(o.size);
  if (!size) return std::unexpected(size.error());
  opts.camera.width = size->first;
  opts.camera.height = size->second;
  auto cam = eval::parseCamera(o.camera, opts.camera);
  if (!cam) return std::unexpected(cam.error());
  opts.camera = *cam;
  auto hour = parseTimeOfDay(o.time);
  if (!hour) return std::unexpected(hour.error());
  opts.hour = *hour;
  opts.reference = o.reference;
  opts.reference_samples = o.samples;
  opts.exposure = o.exposure;
  opts.smooth_fill = o.smooth;
  if (o.smooth && !o.technique.empty()) return fail("--smooth and --technique: give one (--technique drtv-smooth is --smooth)");
  opts.technique = o.technique;
  auto params = eval::parseTechniqueParams(o.params);
  if (!params) return std::unexpected(params.error().context("--params"));
  opts.technique_params = *params;
  opts.threads = o.threads;
  opts.seed = o.seed;
  auto world = worlds::loadWorld(o.world);
  if (!world) return std::unexpected(world.error());
  auto result = eval::render(*world, o.world, o.archive, opts);
  if (!result) return std::unexpected(result.error());
  if (auto made = createParentFolder(o.output); !made) return std::unexpected(made.error());
  auto written = eval::writeRenderImages(*result, o.output);
  if (!written) return std::unexpected(written.error());

  const eval::RenderStats& s = result->stats;
  nlohmann::json j;
  j["archive"] = o.archive;
  j["world"] = o.world;
  j["time"] = o.time;
  j["camera"] = o.camera;
  j["size"] = {opts.camera.width, opts.camera.height};
  j["sectors_loaded"] = s.sectors_loaded;
  j["pixels_hit"] = s.pixels_hit;
  j["exposure"] = s.exposure;
  j["preview_s"] = s.preview_s;
  j["preview_mean_ambient"] = rgb(s.preview_mean_ambient);
  nlohmann::json files = nlohmann::json::array();
  for (const auto& p : *written) files.push_back(p.string());
  j["images"] = files;
  if (o.reference) {
    j["reference_samples"] = o.samples;
    j["reference_s"] = s.reference_s;
    j["reference_mean_ambient"] = rgb(s.reference_mean_ambient);
    j["mean_abs_rel_error"] = s.mean_abs_rel_error;
    j["mean_rel_error"] = s.mean_rel_error;
    j["reference_rel_std_error"] = s.reference_rel_std_error;
    j["blocks"] = {{"pixels", s.block_pixels}, {"count", s.error_blocks}, {"mean_abs_rel_error", s.block_abs_rel_error},
                   {"mean_rel_error", s.block_rel_error}, {"reference_rel_std_error", s.block_reference_rel_std_error}};
  }
  const std::filesystem::path json_path = std::filesystem::path(o.output).replace_extension(".json");
  std::ofstream f(json_path);
  f << j.dump(2) << "\n";
  if (!f) return fail(json_path.string() + ": cannot write");

  for (const auto& p : *written) std::printf("wrote %s\n", p.string().c_str());
  std::printf("%zu sectors resident, %zu of %zu pixels hit geometry, preview %.2f s\n", s.sectors_loaded, s.pixels_hit,
              s.pixels, s.preview_s);
  if (o.reference)
    std::printf("reference %d paths/pixel in %.2f s: ambient mean |relative error| %.1f%%, bias %+.1f%% "
                "(reference noise %.1f%%); in %dx%d-pixel blocks %.1f%%, bias %+.1f%% (noise %.1f%%)\n",
                o.samples, s.reference_s, 100 * s.mean_abs_rel_error, 100 * s.mean_rel_error, 100 * s.reference_rel_std_error,
                s.block_pixels, s.block_pixels, 100 * s.block_abs_rel_error, 100 * s.block_rel_error, 100 * s.block_reference_rel_std_error);
  return {};
}

}  // namespace

Command registerRender(CLI::App& app) {
  auto o = std::make_shared<RenderCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "render", "CPU preview of a baked archive (ambient + direct light); --reference adds path-traced and error images");
  sub->add_option("archive", o->archive, "Baked archive (.drtv)")->required();
  sub->add_option("--world", o->world, "The world file the archive was baked from")->required();
  sub->add_option("--camera", o->camera, "px,py,pz:tx,ty,tz[:fov_deg] (world metres; target at the centre)")->capture_default_str();
  sub->add_option("--size", o->size, "Image size WxH in pixels")->capture_default_str();
  sub->add_option("--time", o->time, "Time of day HH:MM")->capture_default_str();
  sub->add_option("-o,--output", o->output, "PNG to write (<stem>_reference.png, <stem>_error.png, <stem>.json beside it)")
      ->capture_default_str();
  sub->add_flag("--reference", o->reference, "Also path-trace the reference and write the error image");
  sub->add_option("--samples", o->samples, "Reference paths per pixel")->check(CLI::Range(2, 1 << 20))->capture_default_str();
  sub->add_option("--exposure", o->exposure, "Radiance multiplier before tone mapping (0 = automatic)")
      ->check(finiteRange(0.0, 1e9));
  sub->add_flag("--smooth", o->smooth, "Smooth (trilinear over index cells) volume fill instead of nearest probe");
  const std::string names = eval::registeredTechniqueNames();
  sub->add_option("--technique", o->technique, "The GI technique that shades the preview: " + names + " (default drtv-nearest)");
  sub->add_option("--params", o->params, "The technique's parameters, name=value,... (e.g. fill=smooth,texel_m=1)");
  sub->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  sub->add_option("--seed", o->seed, "Seed of the reference's random numbers");
  return {sub, [o]() -> Result<void> { return run(*o); }, &o->archive};
}

}  // namespace drtv::app
