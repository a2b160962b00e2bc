#include "drtv/formats/representation.h"

namespace drtv {

const char* representationName(Representation r) {
  switch (r) {
    case Representation::kFc3: return "fc3";
    case Representation::kShL1: return "sh-l1";
  }
  return "unknown";
}

std::optional<Representation> parseRepresentation(std::string_view name) {
  for (uint32_t i = 0; i < kRepresentationCount; ++i)
    if (name == representationName(Representation(i))) return Representation(i);
  return std::nullopt;
}

std::string representationNames() {
  std::string s;
  for (uint32_t i = 0; i < kRepresentationCount; ++i) s += (i ? ", " : "") + std::string(representationName(Representation(i)));
  return s;
}

}  // namespace drtv
