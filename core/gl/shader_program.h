// Shader programs built from the GLSL files embedded from shaders/
// (shaders/embedded_shaders.h).
//
// The files carry no #version line: kGlslVersion is prepended here, the one
// place that names the GLSL version. `#include "name.glsl"` lines (alone on a
// line) are replaced by the embedded file of that name, recursively, each file
// at most once per shader (so includes need no guards). `#line` directives
// keep compiler messages pointing at the right file and line; the error lists
// which source-string number is which file.
//
// Threading: Build* calls need a current GL context (see gl_objects.h).
#ifndef MVBRDF_CORE_GL_SHADER_PROGRAM_H_
#define MVBRDF_CORE_GL_SHADER_PROGRAM_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"

namespace mvbrdf::gl {

inline constexpr char kGlslVersion[] = "#version 450 core";

struct ShaderStage {
  GLenum type = GL_VERTEX_SHADER;  // GL_VERTEX_SHADER, GL_FRAGMENT_SHADER, GL_GEOMETRY_SHADER, ...
  // Embedded file name, e.g. "phong.frag"; errors name it.
  std::string name;
  // When set, compiled instead of the embedded file `name` (tests, generated
  // code); its #include lines still resolve against the embedded files.
  std::optional<std::string> source;
};

// `source` (the text of file `name`) with the version line prepended and the
// includes expanded. NOT_FOUND naming the including file for a missing include.
absl::StatusOr<std::string> PreprocessShader(absl::string_view name, absl::string_view source);

// PreprocessShader of the embedded file `name`; NOT_FOUND if there is none.
absl::StatusOr<std::string> LoadShader(absl::string_view name);

// Compiles and links the stages. Compile errors name the stage and the shader
// and carry the driver's info log; link errors name every shader.
absl::StatusOr<Program> BuildProgram(const std::vector<ShaderStage>& stages);

}  // namespace mvbrdf::gl

#endif  // MVBRDF_CORE_GL_SHADER_PROGRAM_H_
