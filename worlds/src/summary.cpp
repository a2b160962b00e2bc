// summary.cpp — see drtv/worlds/summary.h.
#include "drtv/worlds/summary.h"

#include <cctype>
#include <cmath>
#include <map>
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

namespace {

// A note's form: each number (digits with their point, sign and exponent) as '#', each quoted
// name ('...' or "...") as '…'.
std::string noteForm(const std::string& note) {
  std::string form;
  for (size_t i = 0; i < note.size();) {
    const char c = note[i];
    if (c == '\'' || c == '"') {
      const size_t close = note.find(c, i + 1);
      if (close != std::string::npos) {
        form += c;
        form += "\u2026";
        form += c;
        i = close + 1;
        continue;
      }
    }
    if (std::isdigit(static_cast<unsigned char>(c))) {
      while (i < note.size() && (std::isdigit(static_cast<unsigned char>(note[i])) || note[i] == '.' || note[i] == 'e' ||
                                 ((note[i] == '-' || note[i] == '+') && i > 0 && note[i - 1] == 'e')))
        ++i;
      form += '#';
      continue;
    }
    form += c;
    ++i;
  }
  return form;
}

std::string thousands(size_t n) {
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

}  // namespace

std::vector<std::string> collapseNotes(std::span<const std::string> notes) {
  std::vector<std::pair<std::string, std::vector<size_t>>> forms;  // in order of first appearance
  std::map<std::string, size_t> index;
  for (size_t i = 0; i < notes.size(); ++i) {
    std::string form = noteForm(notes[i]);
    auto [at, fresh] = index.try_emplace(form, forms.size());
    if (fresh) forms.push_back({std::move(form), {}});
    forms[at->second].second.push_back(i);
  }
  std::vector<std::string> out;
  for (const auto& [form, members] : forms) {
    const size_t shown = members.size() <= kNotesOfAForm + 1 ? members.size() : kNotesOfAForm;
    for (size_t k = 0; k < shown; ++k) out.push_back(notes[members[k]]);
    if (shown < members.size()) out.push_back("... and " + thousands(members.size() - shown) + " more like these: " + form);
  }
  return out;
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
