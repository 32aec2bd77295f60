#include "core/gl/gl_objects.h"

#include <string>

#include "absl/strings/str_cat.h"

namespace mvbrdf::gl {

Texture CreateTexture(GLenum target) {
  GLuint id = 0;
  glCreateTextures(target, 1, &id);
  return Texture(id);
}

Framebuffer CreateFramebuffer() {
  GLuint id = 0;
  glCreateFramebuffers(1, &id);
  return Framebuffer(id);
}

Renderbuffer CreateRenderbuffer() {
  GLuint id = 0;
  glCreateRenderbuffers(1, &id);
  return Renderbuffer(id);
}

Buffer CreateBuffer() {
  GLuint id = 0;
  glCreateBuffers(1, &id);
  return Buffer(id);
}

VertexArray CreateVertexArray() {
  GLuint id = 0;
  glCreateVertexArrays(1, &id);
  return VertexArray(id);
}

const char* GlErrorName(GLenum error) {
  switch (error) {
    case GL_NO_ERROR:
      return "GL_NO_ERROR";
    case GL_INVALID_ENUM:
      return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE:
      return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION:
      return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION:
      return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY:
      return "GL_OUT_OF_MEMORY";
    case GL_STACK_UNDERFLOW:
      return "GL_STACK_UNDERFLOW";
    case GL_STACK_OVERFLOW:
      return "GL_STACK_OVERFLOW";
    case GL_CONTEXT_LOST:
      return "GL_CONTEXT_LOST";
    default:
      return "unknown GL error";
  }
}

absl::Status CheckGlError(absl::string_view what) {
  std::string errors;
  bool out_of_memory = false;
  // Bounded: a lost context may report GL_CONTEXT_LOST forever.
  for (int i = 0; i < 16; ++i) {
    const GLenum error = glGetError();
    if (error == GL_NO_ERROR) break;
    out_of_memory = out_of_memory || error == GL_OUT_OF_MEMORY;
    absl::StrAppend(&errors, errors.empty() ? "" : ", ", GlErrorName(error));
  }
  if (errors.empty()) return absl::OkStatus();
  // Out of memory is the machine's limit (exit 4), not a bug of ours.
  if (out_of_memory) return absl::ResourceExhaustedError(absl::StrCat(what, ": ", errors, " (out of memory)"));
  return absl::InternalError(absl::StrCat(what, ": ", errors));
}

namespace {
const char* FramebufferStatusName(GLenum status) {
  switch (status) {
    case GL_FRAMEBUFFER_COMPLETE:
      return "GL_FRAMEBUFFER_COMPLETE";
    case GL_FRAMEBUFFER_UNDEFINED:
      return "GL_FRAMEBUFFER_UNDEFINED";
    case GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT:
      return "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT:
      return "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT";
    case GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER:
      return "GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER";
    case GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER:
      return "GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER";
    case GL_FRAMEBUFFER_UNSUPPORTED:
      return "GL_FRAMEBUFFER_UNSUPPORTED";
    case GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE:
      return "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE";
    case GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS:
      return "GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS";
    default:
      return "unknown framebuffer status";
  }
}
}  // namespace

absl::Status CheckFramebufferComplete(const Framebuffer& framebuffer, absl::string_view what) {
  const GLenum status = glCheckNamedFramebufferStatus(framebuffer.id(), GL_FRAMEBUFFER);
  if (status == GL_FRAMEBUFFER_COMPLETE) return absl::OkStatus();
  if (status == 0) return CheckGlError(absl::StrCat(what, ": glCheckNamedFramebufferStatus"));
  // Every caller checks right after giving the attachments storage of
  // renderable formats, so an incomplete attachment (or GL_OUT_OF_MEMORY
  // pending) means the storage could not be allocated: llvmpipe under
  // ulimit -v leaves it empty. That is the environment's memory, exit 4.
  bool out_of_memory = status == GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT;
  for (GLenum error = glGetError(); error != GL_NO_ERROR; error = glGetError()) out_of_memory |= error == GL_OUT_OF_MEMORY;
  if (out_of_memory) {
    return absl::ResourceExhaustedError(
        absl::StrCat(what, ": out of memory (", FramebufferStatusName(status), ": its storage could not be allocated)"));
  }
  return absl::InternalError(absl::StrCat(what, ": framebuffer incomplete: ", FramebufferStatusName(status)));
}

}  // namespace mvbrdf::gl
