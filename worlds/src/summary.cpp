// summary.cpp — see drtv/worlds/summary.h.
#include "drtv/worlds/summary.h"

#include <cmath>
#include <sstream>

namespace drtv::worlds {

WorldSummary summarize(const World& world) {
  WorldSummary s;
  s.name = world.name;
  s.meshes = world.meshes.size();
  s.instances = world.instances.size();
  s.triangles = world.triangleCount();
  s.instances_by_class = world.instancesByClass();
  s.bounds = world.bounds();
  if (!s.bounds.empty()) {
    s.sector_min_x = static_cast<int64_t>(std::floor(s.bounds.min.x / kSectorSizeM));
    s.sector_max_x = static_cast<int64_t>(std::floor(s.bounds.max.x / kSectorSizeM));
    s.sector_min_y = static_cast<int64_t>(std::floor(s.bounds.min.y / kSectorSizeM));
    s.sector_max_y = static_cast<int64_t>(std::floor(s.bounds.max.y / kSectorSizeM));
    s.sectors = size_t(s.sector_max_x - s.sector_min_x + 1) * size_t(s.sector_max_y - s.sector_min_y + 1);
  }
  s.effects = world.effects;
  s.effects_explicit = world.effects_explicit;
  s.lights = world.lights.size();
  s.interiors = world.interiors.size();
  s.notes = world.notes.size();
  s.materials = world.materials;
  return s;
}

std::vector<std::pair<const char*, size_t>> materialCountFields(const MaterialCounts& c) {
  return {{"materials", c.materials},
          {"opaque", c.opaque},
          {"mask_kept", c.mask_kept},
          {"mask_skipped", c.mask_skipped},
          {"blend_kept", c.blend_kept},
          {"blend_skipped", c.blend_skipped},
          {"metallic", c.metallic},
          {"emissive", c.emissive},
          {"double_sided", c.double_sided},
          {"emissive_lights", c.emissive_lights},
          {"emissive_instances_not_converted", c.emissive_instances_not_converted}};
}

std::string materialCountsLine(const MaterialCounts& c) {
  std::ostringstream o;
  const auto fields = materialCountFields(c);
  o << "materials: " << fields[0].second << " (";
  for (size_t i = 1; i < fields.size(); ++i) {
    std::string name = fields[i].first;
    for (char& ch : name) ch = ch == '_' ? ' ' : ch;
    o << (i > 1 ? ", " : "") << name << " " << fields[i].second;
  }
  o << ")";
  return o.str();
}

std::string toString(const WorldSummary& s) {
  std::ostringstream o;
  o << "world: " << s.name << "\n"
    << "meshes: " << s.meshes << "\n"
    << "instances: " << s.instances << " (";
  for (size_t c = 0; c < 4; ++c)
    o << (c ? ", " : "") << instanceClassName(static_cast<InstanceClass>(c)) << " " << s.instances_by_class[c];
  o << ")\n"
    << "triangles: " << s.triangles << "\n";
  if (s.bounds.empty()) {
    o << "bounds: empty\n";
  } else {
    o << "bounds: [" << s.bounds.min.x << ", " << s.bounds.min.y << ", " << s.bounds.min.z << "] .. [" << s.bounds.max.x
      << ", " << s.bounds.max.y << ", " << s.bounds.max.z << "] m\n";
  }
  o << "sectors: " << s.sectors << " (x " << s.sector_min_x << ".." << s.sector_max_x << ", y " << s.sector_min_y << ".."
    << s.sector_max_y << ", " << kSectorSizeM << " m)\n"
    << "effects: " << effectsToString(s.effects) << (s.effects_explicit ? " (explicit)" : " (default)") << "\n"
    << "lights: " << s.lights << "\n"
    << "interiors: " << s.interiors << "\n"
    << materialCountsLine(s.materials) << "\n"
    << "notes: " << s.notes << "\n";
  return o.str();
}

}  // namespace drtv::worlds
