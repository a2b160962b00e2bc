// drtv map <world> -o map.png [--size px]: a top-down picture of a world.
#include <memory>

#include "commands.h"
#include "drtv/worlds/load.h"
#include "drtv/eval/topdown.h"

namespace drtv::app {

Command registerMap(CLI::App& app) {
  struct Options {
    std::string world, out = "map.png";
    int size = 1024;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("map", "Draw a world from above (terrain, objects, interiors, 64 m sectors) as a PNG");
  sub->add_option("world", o->world, "World file (.json, .gltf, .glb)")->required();
  sub->add_option("-o,--output", o->out, "PNG to write")->capture_default_str();
  sub->add_option("--size", o->size, "Longer side in pixels")->check(CLI::Range(16, 16384))->capture_default_str();
  return {sub, [o]() -> Result<void> {
            auto world = worlds::loadWorld(o->world);
            if (!world) return std::unexpected(world.error());
            eval::TopDownOptions opts;
            opts.max_size_px = o->size;
            if (auto made = createParentFolder(o->out); !made) return made;
            return image::writePng(o->out, eval::renderTopDown(*world, opts));
          }, &o->world};
}

}  // namespace drtv::app
