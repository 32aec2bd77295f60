#include "core/gl/egl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <map>
#include <mutex>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/gl/gl_api.h"

namespace mvbrdf::gl {
namespace {

const char* EglErrorName(EGLint error) {
  switch (error) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE:
      return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP:
      return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW:
      return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE:
      return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST:
      return "EGL_CONTEXT_LOST";
    case EGL_BAD_DEVICE_EXT:
      return "EGL_BAD_DEVICE_EXT";
    default:
      return "unknown EGL error";
  }
}

// `what` failed: the status names the call and the EGL error code.
absl::Status EglError(absl::string_view what) {
  const EGLint error = eglGetError();
  // EGL not usable here: the environment's (exit 4), not a bug of ours.
  return absl::UnavailableError(absl::StrCat(what, " failed: ", EglErrorName(error), " (0x", absl::Hex(error), ")"));
}

bool HasExtension(const char* extensions, absl::string_view name) {
  if (extensions == nullptr) return false;
  for (absl::string_view token : absl::StrSplit(extensions, ' ', absl::SkipEmpty())) {
    if (token == name) return true;
  }
  return false;
}

template <typename Fn>
Fn LoadEglFunction(const char* name) {
  return reinterpret_cast<Fn>(eglGetProcAddress(name));
}

// EGL displays are per process: eglGetPlatformDisplay returns the same handle
// for the same arguments, and eglTerminate would pull it from under every
// other EglContext on it. So initialisation is reference-counted per display.
// This guards only EGL's own process-wide display state, not GL state.
std::mutex& DisplayMutex() {
  static std::mutex* mutex = new std::mutex;
  return *mutex;
}
std::map<EGLDisplay, int>& DisplayRefCounts() {
  static auto* counts = new std::map<EGLDisplay, int>;
  return *counts;
}

absl::Status AcquireDisplay(EGLDisplay display) {
  std::lock_guard<std::mutex> lock(DisplayMutex());
  int& count = DisplayRefCounts()[display];
  if (count == 0) {
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor)) {
      DisplayRefCounts().erase(display);
      return EglError("eglInitialize");
    }
  }
  ++count;
  return absl::OkStatus();
}

void ReleaseDisplay(EGLDisplay display) {
  std::lock_guard<std::mutex> lock(DisplayMutex());
  auto it = DisplayRefCounts().find(display);
  if (it == DisplayRefCounts().end()) return;
  if (--it->second == 0) {
    eglTerminate(display);
    DisplayRefCounts().erase(it);
  }
}

absl::StatusOr<EGLDisplay> SurfacelessDisplay() {
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!HasExtension(client_extensions, "EGL_MESA_platform_surfaceless")) {
    return absl::UnavailableError("EGL platform surfaceless: EGL_MESA_platform_surfaceless is not supported");
  }
  auto get_platform_display = LoadEglFunction<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  if (get_platform_display == nullptr) {
    return absl::UnavailableError("EGL platform surfaceless: eglGetPlatformDisplayEXT is not available");
  }
  EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (display == EGL_NO_DISPLAY) return EglError("eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA)");
  return display;
}

// The display of the first EGL device that is not a software renderer;
// NOT_FOUND when there is none (e.g. llvmpipe only).
absl::StatusOr<EGLDisplay> HardwareDeviceDisplay() {
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!HasExtension(client_extensions, "EGL_EXT_platform_device")) {
    return absl::UnavailableError("EGL platform device: EGL_EXT_platform_device is not supported");
  }
  auto query_devices = LoadEglFunction<PFNEGLQUERYDEVICESEXTPROC>("eglQueryDevicesEXT");
  auto query_device_string = LoadEglFunction<PFNEGLQUERYDEVICESTRINGEXTPROC>("eglQueryDeviceStringEXT");
  auto get_platform_display = LoadEglFunction<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  if (query_devices == nullptr || query_device_string == nullptr || get_platform_display == nullptr) {
    return absl::UnavailableError("EGL platform device: device enumeration functions are not available");
  }
  EGLint num_devices = 0;
  if (!query_devices(0, nullptr, &num_devices)) return EglError("eglQueryDevicesEXT");
  std::vector<EGLDeviceEXT> devices(static_cast<size_t>(num_devices));
  if (num_devices > 0 && !query_devices(num_devices, devices.data(), &num_devices)) {
    return EglError("eglQueryDevicesEXT");
  }
  for (EGLint i = 0; i < num_devices; ++i) {
    const char* extensions = query_device_string(devices[i], EGL_EXTENSIONS);
    if (HasExtension(extensions, "EGL_MESA_device_software")) continue;
    EGLDisplay display = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
    if (display == EGL_NO_DISPLAY) return EglError("eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT)");
    return display;
  }
  return absl::UnavailableError(
      absl::StrCat("EGL platform device: none of the ", num_devices,
                   " EGL devices is a hardware device (all report EGL_MESA_device_software); use platform "
                   "\"surfaceless\" or \"auto\""));
}

std::string GlString(GLenum name) {
  const GLubyte* s = glGetString(name);
  return s == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(s));
}

}  // namespace

absl::StatusOr<EglPlatform> ParseEglPlatform(absl::string_view name) {
  const std::string lower = absl::AsciiStrToLower(name);
  if (lower == "auto") return EglPlatform::kAuto;
  if (lower == "surfaceless") return EglPlatform::kSurfaceless;
  if (lower == "device") return EglPlatform::kDevice;
  return absl::InvalidArgumentError(
      absl::StrCat("EGL platform: expected \"auto\", \"surfaceless\" or \"device\", got \"", name, "\""));
}

const char* EglPlatformName(EglPlatform platform) {
  switch (platform) {
    case EglPlatform::kAuto:
      return "auto";
    case EglPlatform::kSurfaceless:
      return "surfaceless";
    case EglPlatform::kDevice:
      return "device";
  }
  return "unknown";
}

struct EglContext::Impl {
  EglPlatform platform = EglPlatform::kSurfaceless;
  EGLDisplay display = EGL_NO_DISPLAY;
  bool display_acquired = false;
  EGLContext context = EGL_NO_CONTEXT;
  std::string gl_renderer;
  std::string gl_version;
  std::string egl_vendor;

  ~Impl() {
    if (context != EGL_NO_CONTEXT) {
      if (eglGetCurrentContext() == context) {
        eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      }
      eglDestroyContext(display, context);
    }
    if (display_acquired) ReleaseDisplay(display);
  }
};

absl::StatusOr<std::unique_ptr<EglContext>> EglContext::Create(EglPlatform platform) {
  if (platform == EglPlatform::kAuto) {
    // Prefer a hardware device, but fall back to surfaceless whenever any step
    // on the device fails (no device, eglInitialize, no GL 4.5 core context).
    auto on_device = Create(EglPlatform::kDevice);
    if (on_device.ok()) return on_device;
    return Create(EglPlatform::kSurfaceless);
  }
  auto impl = std::make_unique<Impl>();
  absl::StatusOr<EGLDisplay> display;
  switch (platform) {
    case EglPlatform::kSurfaceless:
      display = SurfacelessDisplay();
      impl->platform = EglPlatform::kSurfaceless;
      break;
    case EglPlatform::kDevice:
      display = HardwareDeviceDisplay();
      impl->platform = EglPlatform::kDevice;
      break;
    case EglPlatform::kAuto:  // handled above
      return absl::InternalError("EglContext::Create: unresolved platform auto");
  }
  if (!display.ok()) return display.status();
  impl->display = *display;
  if (absl::Status s = AcquireDisplay(impl->display); !s.ok()) return s;
  impl->display_acquired = true;

  const char* vendor = eglQueryString(impl->display, EGL_VENDOR);
  impl->egl_vendor = vendor == nullptr ? "" : vendor;
  const char* display_extensions = eglQueryString(impl->display, EGL_EXTENSIONS);
  if (!HasExtension(display_extensions, "EGL_KHR_surfaceless_context")) {
    return absl::UnavailableError(absl::StrCat("EGL display of platform ", EglPlatformName(impl->platform),
                                               " lacks EGL_KHR_surfaceless_context"));
  }
  if (!eglBindAPI(EGL_OPENGL_API)) return EglError("eglBindAPI(EGL_OPENGL_API)");

  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!HasExtension(display_extensions, "EGL_KHR_no_config_context")) {
    // Without no-config contexts any OpenGL-renderable config will do: we never
    // create a surface, all rendering goes to framebuffer objects.
    const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLint num_configs = 0;
    if (!eglChooseConfig(impl->display, config_attributes, &config, 1, &num_configs)) {
      return EglError("eglChooseConfig");
    }
    if (num_configs == 0) return absl::UnavailableError("eglChooseConfig: no OpenGL-renderable config");
  }
  const EGLint context_attributes[] = {
      EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  impl->context = eglCreateContext(impl->display, config, EGL_NO_CONTEXT, context_attributes);
  if (impl->context == EGL_NO_CONTEXT) return EglError("eglCreateContext(OpenGL 4.5 core)");

  std::unique_ptr<EglContext> context(new EglContext(std::move(impl)));
  if (absl::Status s = context->MakeCurrent(); !s.ok()) return s;
  context->impl_->gl_renderer = GlString(GL_RENDERER);
  context->impl_->gl_version = GlString(GL_VERSION);
  return context;
}

EglContext::EglContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
EglContext::~EglContext() = default;

absl::Status EglContext::MakeCurrent() {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context)) {
    return EglError("eglMakeCurrent");
  }
  return absl::OkStatus();
}

absl::Status EglContext::ReleaseCurrent() {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT)) {
    return EglError("eglMakeCurrent(EGL_NO_CONTEXT)");
  }
  return absl::OkStatus();
}

bool EglContext::IsCurrent() const { return eglGetCurrentContext() == impl_->context; }

EglPlatform EglContext::platform() const { return impl_->platform; }
const std::string& EglContext::gl_renderer() const { return impl_->gl_renderer; }
const std::string& EglContext::gl_version() const { return impl_->gl_version; }
const std::string& EglContext::egl_vendor() const { return impl_->egl_vendor; }

std::string EglContext::Describe() const {
  return absl::StrCat(EglPlatformName(impl_->platform), ", ", impl_->gl_renderer, ", ", impl_->gl_version);
}

}  // namespace mvbrdf::gl
