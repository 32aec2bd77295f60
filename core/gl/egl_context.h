// An OpenGL 4.5 core context with no window, through EGL.
//
// Platforms: Mesa's surfaceless platform (llvmpipe on machines without a GPU)
// or the EGL device platform (NVIDIA and other GPUs without a display server).
// kAuto picks the first EGL device that is not a software renderer and falls
// back to surfaceless.
//
// Ownership and threading: the context is created current on the calling
// thread; ReleaseCurrent() there and MakeCurrent() on another thread move it. It is passed explicitly to
// whatever renders; there is no global GL state. Destroying it releases the
// context and terminates the display.
#ifndef MVBRDF_CORE_GL_EGL_CONTEXT_H_
#define MVBRDF_CORE_GL_EGL_CONTEXT_H_

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace mvbrdf::gl {

enum class EglPlatform { kAuto, kSurfaceless, kDevice };

// "auto", "surfaceless" or "device".
absl::StatusOr<EglPlatform> ParseEglPlatform(absl::string_view name);
const char* EglPlatformName(EglPlatform platform);

class EglContext {
 public:
  static absl::StatusOr<std::unique_ptr<EglContext>> Create(EglPlatform platform = EglPlatform::kAuto);
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  // Makes the context current on the calling thread (no surface). A context
  // is current on at most one thread: to move it, call ReleaseCurrent() on the
  // old thread first (else EGL_BAD_ACCESS).
  absl::Status MakeCurrent();
  // Makes no context current on the calling thread.
  absl::Status ReleaseCurrent();
  // True when this context is current on the calling thread.
  bool IsCurrent() const;

  // The platform actually used (never kAuto).
  EglPlatform platform() const;
  const std::string& gl_renderer() const;  // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  const std::string& gl_version() const;   // GL_VERSION
  const std::string& egl_vendor() const;   // EGL_VENDOR
  // One line for logs and reports: "surfaceless, llvmpipe (...), 4.5 (Core Profile) Mesa 22.3.6".
  std::string Describe() const;

 private:
  struct Impl;
  explicit EglContext(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mvbrdf::gl

#endif  // MVBRDF_CORE_GL_EGL_CONTEXT_H_
