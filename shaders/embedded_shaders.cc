#include "shaders/embedded_shaders.h"

#include <algorithm>

namespace mvbrdf::shaders {

std::optional<std::string> Find(absl::string_view name) {
  for (int i = 0; i < internal::kNumEmbeddedShaders; ++i) {
    if (name == internal::kEmbeddedShaders[i].name) return std::string(internal::kEmbeddedShaders[i].text);
  }
  return std::nullopt;
}

std::vector<std::string> Names() {
  std::vector<std::string> names;
  names.reserve(internal::kNumEmbeddedShaders);
  for (int i = 0; i < internal::kNumEmbeddedShaders; ++i) names.emplace_back(internal::kEmbeddedShaders[i].name);
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace mvbrdf::shaders
