#include "core/gl/shader_program.h"

#include <algorithm>
#include <cstring>
#include <set>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "shaders/embedded_shaders.h"

namespace mvbrdf::gl {
namespace {

// The file name of an `#include "name"` line, or nullopt for any other line.
std::optional<absl::string_view> IncludedName(absl::string_view line) {
  line = absl::StripAsciiWhitespace(line);
  if (!absl::ConsumePrefix(&line, "#")) return std::nullopt;
  line = absl::StripLeadingAsciiWhitespace(line);
  if (!absl::ConsumePrefix(&line, "include")) return std::nullopt;
  line = absl::StripLeadingAsciiWhitespace(line);
  if (line.size() < 2 || line.front() != '"' || line.back() != '"') return std::nullopt;
  return line.substr(1, line.size() - 2);
}

struct Preprocessor {
  std::vector<std::string> files;  // source-string number -> file name
  std::set<std::string> included;

  absl::Status Expand(absl::string_view name, absl::string_view source, std::string* out) {
    const int file_index = static_cast<int>(files.size());
    files.emplace_back(name);
    included.emplace(name);
    absl::StrAppend(out, "#line 1 ", file_index, "\n");
    int line_number = 0;
    for (absl::string_view line : absl::StrSplit(source, '\n')) {
      ++line_number;
      const std::optional<absl::string_view> include = IncludedName(line);
      if (!include.has_value()) {
        absl::StrAppend(out, line, "\n");
        continue;
      }
      const std::string include_name(*include);
      if (included.count(include_name) == 0) {
        const std::optional<std::string> text = shaders::Find(include_name);
        if (!text.has_value()) {
          return absl::NotFoundError(absl::StrCat("shader \"", name, "\" line ", line_number,
                                                  ": no embedded shader file \"", include_name, "\""));
        }
        if (absl::Status s = Expand(include_name, *text, out); !s.ok()) return s;
      }
      absl::StrAppend(out, "#line ", line_number + 1, " ", file_index, "\n");
    }
    return absl::OkStatus();
  }

  std::string Legend() const {
    std::vector<std::string> entries;
    for (size_t i = 0; i < files.size(); ++i) entries.push_back(absl::StrCat(i, " = ", files[i]));
    return absl::StrCat("source strings: ", absl::StrJoin(entries, ", "));
  }
};

const char* StageName(GLenum type) {
  switch (type) {
    case GL_VERTEX_SHADER:
      return "vertex";
    case GL_FRAGMENT_SHADER:
      return "fragment";
    case GL_GEOMETRY_SHADER:
      return "geometry";
    case GL_COMPUTE_SHADER:
      return "compute";
    case GL_TESS_CONTROL_SHADER:
      return "tessellation control";
    case GL_TESS_EVALUATION_SHADER:
      return "tessellation evaluation";
    default:
      return "unknown-stage";
  }
}

std::string ShaderInfoLog(GLuint shader) {
  GLint length = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<size_t>(std::max(length, 1)), '\0');
  glGetShaderInfoLog(shader, length, nullptr, log.data());
  log.resize(std::strlen(log.c_str()));
  return log;
}

std::string ProgramInfoLog(GLuint program) {
  GLint length = 0;
  glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<size_t>(std::max(length, 1)), '\0');
  glGetProgramInfoLog(program, length, nullptr, log.data());
  log.resize(std::strlen(log.c_str()));
  return log;
}

}  // namespace

absl::StatusOr<std::string> PreprocessShader(absl::string_view name, absl::string_view source) {
  Preprocessor preprocessor;
  std::string out = absl::StrCat(kGlslVersion, "\n");
  if (absl::Status s = preprocessor.Expand(name, source, &out); !s.ok()) return s;
  return out;
}

absl::StatusOr<std::string> LoadShader(absl::string_view name) {
  const std::optional<std::string> text = shaders::Find(name);
  if (!text.has_value()) return absl::NotFoundError(absl::StrCat("no embedded shader file \"", name, "\""));
  return PreprocessShader(name, *text);
}

absl::StatusOr<Program> BuildProgram(const std::vector<ShaderStage>& stages) {
  if (stages.empty()) return absl::InvalidArgumentError("BuildProgram: no shader stages");
  std::vector<Shader> shaders;
  std::vector<std::string> names;
  for (const ShaderStage& stage : stages) {
    names.push_back(stage.name);
    Preprocessor preprocessor;
    std::string text = absl::StrCat(kGlslVersion, "\n");
    absl::Status status;
    if (stage.source.has_value()) {
      status = preprocessor.Expand(stage.name, *stage.source, &text);
    } else {
      const std::optional<std::string> file = shaders::Find(stage.name);
      if (!file.has_value()) {
        return absl::NotFoundError(absl::StrCat("no embedded shader file \"", stage.name, "\""));
      }
      status = preprocessor.Expand(stage.name, *file, &text);
    }
    if (!status.ok()) return status;

    Shader shader(glCreateShader(stage.type));
    if (!shader) return CheckGlError(absl::StrCat("glCreateShader for \"", stage.name, "\""));
    const char* text_ptr = text.c_str();
    glShaderSource(shader.id(), 1, &text_ptr, nullptr);
    glCompileShader(shader.id());
    GLint compiled = GL_FALSE;
    glGetShaderiv(shader.id(), GL_COMPILE_STATUS, &compiled);
    if (compiled != GL_TRUE) {
      return absl::InternalError(absl::StrCat("compiling ", StageName(stage.type), " shader \"", stage.name,
                                              "\" failed (", preprocessor.Legend(), "):\n",
                                              ShaderInfoLog(shader.id())));
    }
    shaders.push_back(std::move(shader));
  }

  Program program(glCreateProgram());
  if (!program) return CheckGlError("glCreateProgram");
  for (const Shader& shader : shaders) glAttachShader(program.id(), shader.id());
  glLinkProgram(program.id());
  GLint linked = GL_FALSE;
  glGetProgramiv(program.id(), GL_LINK_STATUS, &linked);
  for (const Shader& shader : shaders) glDetachShader(program.id(), shader.id());
  if (linked != GL_TRUE) {
    return absl::InternalError(absl::StrCat("linking program of shaders \"", absl::StrJoin(names, "\", \""),
                                            "\" failed:\n", ProgramInfoLog(program.id())));
  }
  if (absl::Status s = CheckGlError(absl::StrCat("building program \"", absl::StrJoin(names, "\", \""), "\""));
      !s.ok()) {
    return s;
  }
  return program;
}

}  // namespace mvbrdf::gl
