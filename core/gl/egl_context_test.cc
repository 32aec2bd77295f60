#include "core/gl/egl_context.h"

#include <gtest/gtest.h>

#include <thread>

#include "core/gl/gl_api.h"
#include "core/gl/gl_objects.h"

namespace mvbrdf::gl {
namespace {

TEST(EglPlatformTest, ParsesNamesCaseInsensitively) {
  EXPECT_EQ(*ParseEglPlatform("auto"), EglPlatform::kAuto);
  EXPECT_EQ(*ParseEglPlatform("surfaceless"), EglPlatform::kSurfaceless);
  EXPECT_EQ(*ParseEglPlatform("Device"), EglPlatform::kDevice);
  for (EglPlatform p : {EglPlatform::kAuto, EglPlatform::kSurfaceless, EglPlatform::kDevice}) {
    EXPECT_EQ(*ParseEglPlatform(EglPlatformName(p)), p);
  }
}

TEST(EglPlatformTest, RejectsUnknownNameAndSaysWhatIsExpected) {
  const absl::StatusOr<EglPlatform> p = ParseEglPlatform("x11");
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(p.status().message().find("x11"), absl::string_view::npos);
  EXPECT_NE(p.status().message().find("surfaceless"), absl::string_view::npos);
}

TEST(EglContextTest, SurfacelessGivesCurrentGl45CoreContext) {
  absl::StatusOr<std::unique_ptr<EglContext>> context = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  EXPECT_EQ((*context)->platform(), EglPlatform::kSurfaceless);
  EXPECT_TRUE((*context)->IsCurrent());
  GLint major = 0, minor = 0, profile = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
  EXPECT_GE(major * 10 + minor, 45);
  EXPECT_TRUE(profile & GL_CONTEXT_CORE_PROFILE_BIT);
  EXPECT_FALSE((*context)->gl_renderer().empty());
  EXPECT_NE((*context)->Describe().find("surfaceless"), std::string::npos);
  EXPECT_TRUE(CheckGlError("query").ok());
}

TEST(EglContextTest, AutoFallsBackToSurfacelessOnSoftwareRenderer) {
  absl::StatusOr<std::unique_ptr<EglContext>> context = EglContext::Create(EglPlatform::kAuto);
  ASSERT_TRUE(context.ok()) << context.status();
  EXPECT_NE((*context)->platform(), EglPlatform::kAuto);
  // On this project's development machines (no GPU) auto means llvmpipe
  // through surfaceless; on a GPU machine it means the device platform.
  if ((*context)->gl_renderer().find("llvmpipe") != std::string::npos) {
    EXPECT_EQ((*context)->platform(), EglPlatform::kSurfaceless);
    EXPECT_NE((*context)->Describe().find("llvmpipe"), std::string::npos) << (*context)->Describe();
  } else {
    EXPECT_EQ((*context)->platform(), EglPlatform::kDevice);
  }
}

TEST(EglContextTest, DeviceWithoutHardwareIsACleanError) {
  absl::StatusOr<std::unique_ptr<EglContext>> context = EglContext::Create(EglPlatform::kDevice);
  if (context.ok()) {
    // A machine with a GPU: the device must not be the software renderer.
    EXPECT_EQ((*context)->gl_renderer().find("llvmpipe"), std::string::npos);
    return;
  }
  EXPECT_TRUE(absl::IsNotFound(context.status()) || absl::IsUnavailable(context.status())) << context.status();
  EXPECT_NE(context.status().message().find("device"), absl::string_view::npos) << context.status();
}

TEST(EglContextTest, TwoContextsShareTheDisplaySafely) {
  auto first = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(first.ok()) << first.status();
  {
    auto second = EglContext::Create(EglPlatform::kSurfaceless);
    ASSERT_TRUE(second.ok()) << second.status();
    EXPECT_TRUE((*second)->IsCurrent());
    EXPECT_FALSE((*first)->IsCurrent());
  }
  // Destroying the second must not terminate the display under the first.
  ASSERT_TRUE((*first)->MakeCurrent().ok());
  Texture texture = CreateTexture(GL_TEXTURE_2D);
  EXPECT_TRUE(texture);
  EXPECT_TRUE(CheckGlError("create texture after the second context went").ok());
}

TEST(EglContextTest, MovesToAnotherThreadAndBack) {
  auto context = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  ASSERT_TRUE((*context)->ReleaseCurrent().ok());
  EXPECT_FALSE((*context)->IsCurrent());
  absl::Status on_worker;
  bool was_current = false;
  std::string renderer;
  std::thread worker([&] {
    on_worker = (*context)->MakeCurrent();
    was_current = (*context)->IsCurrent();
    renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    if (on_worker.ok()) on_worker = (*context)->ReleaseCurrent();
  });
  worker.join();
  EXPECT_TRUE(on_worker.ok()) << on_worker;
  EXPECT_TRUE(was_current);
  EXPECT_EQ(renderer, (*context)->gl_renderer());
  EXPECT_TRUE((*context)->MakeCurrent().ok());
}

TEST(GlObjectsTest, HandlesAreMoveOnlyAndFreeTheirName) {
  auto context = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  Buffer a = CreateBuffer();
  const GLuint id = a.id();
  ASSERT_NE(id, 0u);
  EXPECT_TRUE(glIsBuffer(id));
  Buffer b = std::move(a);
  EXPECT_EQ(a.id(), 0u);  // NOLINT(bugprone-use-after-move): checking the moved-from state
  EXPECT_EQ(b.id(), id);
  b.Reset();
  EXPECT_FALSE(glIsBuffer(id));
}

TEST(GlObjectsTest, IncompleteFramebufferIsAStatus) {
  auto context = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  Framebuffer framebuffer = CreateFramebuffer();
  const absl::Status status = CheckFramebufferComplete(framebuffer, "empty framebuffer");
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT"), absl::string_view::npos) << status;
}

TEST(GlObjectsTest, CheckGlErrorNamesTheError) {
  auto context = EglContext::Create(EglPlatform::kSurfaceless);
  ASSERT_TRUE(context.ok()) << context.status();
  glEnable(0x1234);  // not a capability
  const absl::Status status = CheckGlError("enable bogus");
  EXPECT_FALSE(status.ok());
  EXPECT_NE(status.message().find("enable bogus: GL_INVALID_ENUM"), absl::string_view::npos) << status;
  EXPECT_TRUE(CheckGlError("after draining").ok());
}

}  // namespace
}  // namespace mvbrdf::gl
