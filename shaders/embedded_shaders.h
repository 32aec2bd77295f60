// The GLSL sources of shaders/, embedded into the binary at build time
// (shaders/embed_shaders.cmake). Lookup is by file name, e.g. "phong.frag".
// The texts are exactly the files: no #version line, #include lines not
// expanded (core/gl/shader_program.h does both).
//
// Thread-safe: the data is immutable.
#ifndef MVBRDF_SHADERS_EMBEDDED_SHADERS_H_
#define MVBRDF_SHADERS_EMBEDDED_SHADERS_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/strings/string_view.h"

namespace mvbrdf::shaders {

// The text of the shader file `name`, or nullopt when no such file is embedded.
std::optional<std::string> Find(absl::string_view name);

// Names of all embedded files, sorted.
std::vector<std::string> Names();

namespace internal {
struct EmbeddedShader {
  const char* name;
  const char* text;
};
// Defined in the generated embedded_shaders_data.cc.
extern const EmbeddedShader kEmbeddedShaders[];
extern const int kNumEmbeddedShaders;
}  // namespace internal

}  // namespace mvbrdf::shaders

#endif  // MVBRDF_SHADERS_EMBEDDED_SHADERS_H_
