// Move-only RAII owners of OpenGL object names, and GL error helpers.
//
// Ownership and threading: an object belongs to the context that was current
// when it was created; it must be destroyed (and used) on a thread where that
// context is current, before the context is destroyed. Objects are created
// with the GL 4.5 direct-state-access calls (glCreate*), so creating one binds
// nothing.
#ifndef MVBRDF_CORE_GL_GL_OBJECTS_H_
#define MVBRDF_CORE_GL_GL_OBJECTS_H_

#include <utility>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "core/gl/gl_api.h"

namespace mvbrdf::gl {

// Owns one GL name; `Deleter::Delete(GLuint)` frees it. 0 means empty.
template <typename Deleter>
class GlHandle {
 public:
  GlHandle() = default;
  explicit GlHandle(GLuint id) : id_(id) {}
  ~GlHandle() { Reset(); }
  GlHandle(const GlHandle&) = delete;
  GlHandle& operator=(const GlHandle&) = delete;
  GlHandle(GlHandle&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
  GlHandle& operator=(GlHandle&& other) noexcept {
    if (this != &other) {
      Reset();
      id_ = std::exchange(other.id_, 0);
    }
    return *this;
  }

  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void Reset() {
    if (id_ != 0) Deleter::Delete(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

namespace internal {
struct TextureDeleter {
  static void Delete(GLuint id) { glDeleteTextures(1, &id); }
};
struct FramebufferDeleter {
  static void Delete(GLuint id) { glDeleteFramebuffers(1, &id); }
};
struct RenderbufferDeleter {
  static void Delete(GLuint id) { glDeleteRenderbuffers(1, &id); }
};
struct BufferDeleter {
  static void Delete(GLuint id) { glDeleteBuffers(1, &id); }
};
struct VertexArrayDeleter {
  static void Delete(GLuint id) { glDeleteVertexArrays(1, &id); }
};
struct ShaderDeleter {
  static void Delete(GLuint id) { glDeleteShader(id); }
};
struct ProgramDeleter {
  static void Delete(GLuint id) { glDeleteProgram(id); }
};
}  // namespace internal

using Texture = GlHandle<internal::TextureDeleter>;
using Framebuffer = GlHandle<internal::FramebufferDeleter>;
using Renderbuffer = GlHandle<internal::RenderbufferDeleter>;
using Buffer = GlHandle<internal::BufferDeleter>;
using VertexArray = GlHandle<internal::VertexArrayDeleter>;
using Shader = GlHandle<internal::ShaderDeleter>;
using Program = GlHandle<internal::ProgramDeleter>;

// Creation through direct state access; `target` e.g. GL_TEXTURE_2D.
Texture CreateTexture(GLenum target);
Framebuffer CreateFramebuffer();
Renderbuffer CreateRenderbuffer();
Buffer CreateBuffer();
VertexArray CreateVertexArray();

// "GL_INVALID_OPERATION", ... for a glGetError() code.
const char* GlErrorName(GLenum error);

// Drains glGetError(); INTERNAL naming `what` and every pending error code if
// any, else OK.
absl::Status CheckGlError(absl::string_view what);

// OK when `framebuffer` is complete, else INTERNAL naming `what` and the
// status (e.g. GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT).
absl::Status CheckFramebufferComplete(const Framebuffer& framebuffer, absl::string_view what);

}  // namespace mvbrdf::gl

#endif  // MVBRDF_CORE_GL_GL_OBJECTS_H_
