// Headless EGL context, GL object wrappers and framebuffer readback.
#include <gtest/gtest.h>

#include <cstdlib>
#include <type_traits>

#include "dentar/ar/egl_context.h"
#include "dentar/ar/gl_objects.h"
#include "gl_test_context.h"

namespace dentar::ar {
namespace {

TEST(EglContext, CreatesGles3ContextHeadless) {
  DENTAR_GL_TEST_CONTEXT();
  const EglContext& ctx = *test::gl_test_context().context;
  EXPECT_NE(ctx.platform(), EglPlatform::kAuto);
  EXPECT_FALSE(ctx.gl_renderer().empty());
  EXPECT_NE(ctx.gl_version().find("OpenGL ES 3"), std::string::npos) << ctx.gl_version();
  GLint major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  EXPECT_GE(major, 3);
}

TEST(EglContext, SecondContextDoesNotTerminateTheFirst) {
  DENTAR_GL_TEST_CONTEXT();
  {
    auto second = EglContext::create();
    ASSERT_TRUE(second.ok()) << second.error();
    EglContext moved = std::move(second).value();  // move keeps one owner
    EXPECT_TRUE(moved.make_current().ok());
  }  // destroyed: must not eglTerminate the display the first context uses
  ASSERT_TRUE(test::gl_test_context().context->make_current().ok());
  Buffer b = make_buffer();
  EXPECT_NE(b.id(), 0u);
  EXPECT_EQ(gl_error_message("after second context"), "");
}

TEST(EglContext, ImpossibleVersionGivesClearError) {
  DENTAR_GL_TEST_CONTEXT();
  EglContextOptions o;
  o.gles_major = 9;  // no such OpenGL ES
  auto r = EglContext::create(o);
  ASSERT_FALSE(r.ok());
  // Names every platform tried, the failing call and an EGL error code.
  EXPECT_NE(r.error().find("surfaceless"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("OpenGL ES 9.0"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("(0x30"), std::string::npos) << r.error();
  std::printf("error: %s\n", r.error().c_str());
}

TEST(EglContext, UnsupportedPlatformGivesClearError) {
  DENTAR_GL_TEST_CONTEXT();
  EglContextOptions o;
  o.platform = EglPlatform::kSurfaceless;
  o.raw_platform_enum_for_test = 0x1234;  // not an EGL platform
  auto r = EglContext::create(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("platform surfaceless"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("0x1234"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("EGL_BAD_PARAMETER"), std::string::npos) << r.error();
  std::printf("error: %s\n", r.error().c_str());
}

TEST(EglContext, EnvironmentVariableSelectsPlatform) {
  DENTAR_GL_TEST_CONTEXT();
  ::setenv("DENTAR_EGL_PLATFORM", "x11", 1);
  auto bad = EglContext::create();
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("DENTAR_EGL_PLATFORM='x11'"), std::string::npos) << bad.error();
  ::setenv("DENTAR_EGL_PLATFORM", "surfaceless", 1);
  auto good = EglContext::create();
  ::unsetenv("DENTAR_EGL_PLATFORM");
  ASSERT_TRUE(good.ok()) << good.error();
  EXPECT_EQ(good->platform(), EglPlatform::kSurfaceless);
}

TEST(EglContext, DevicePlatformWorksOrSaysWhy) {
  DENTAR_GL_TEST_CONTEXT();
  EglContextOptions o;
  o.platform = EglPlatform::kDevice;
  auto r = EglContext::create(o);
  if (r) {
    std::printf("device platform: %s\n", r->description().c_str());
  } else {
    EXPECT_NE(r.error().find("platform device"), std::string::npos) << r.error();
    std::printf("device platform unavailable: %s\n", r.error().c_str());
  }
  o.device_index = 1000;
  auto out_of_range = EglContext::create(o);
  ASSERT_FALSE(out_of_range.ok());
  EXPECT_NE(out_of_range.error().find("platform device"), std::string::npos);
}

TEST(GlObjects, HandlesAreMoveOnly) {
  static_assert(!std::is_copy_constructible_v<Buffer>);
  static_assert(!std::is_copy_assignable_v<Program>);
  static_assert(std::is_nothrow_move_constructible_v<Texture>);
  DENTAR_GL_TEST_CONTEXT();
  Buffer a = make_buffer();
  const GLuint id = a.id();
  Buffer b = std::move(a);
  EXPECT_EQ(a.id(), 0u);  // NOLINT(bugprone-use-after-move): moved-from is empty by contract
  EXPECT_EQ(b.id(), id);
  b.reset();
  EXPECT_EQ(b.id(), 0u);
}

TEST(GlObjects, ShaderErrorNamesTheShader) {
  DENTAR_GL_TEST_CONTEXT();
  auto p = link_program("#version 300 es\nvoid main() { gl_Position = vec4(0); }\n",
                        "#version 300 es\nthis does not compile\n", "broken test shader");
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().find("broken test shader"), std::string::npos) << p.error();
  EXPECT_NE(p.error().find("fragment"), std::string::npos) << p.error();
}

TEST(RenderTarget, ReadbackRowZeroIsTheTop) {
  DENTAR_GL_TEST_CONTEXT();
  constexpr int kW = 8, kH = 6;
  auto t = RenderTarget::create(kW, kH);
  ASSERT_TRUE(t.ok()) << t.error();
  t->bind();
  glDisable(GL_SCISSOR_TEST);
  glClearColor(0, 0, 1, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  // GL window rows H-2, H-1 are the top two rows of the image; column 0 the left.
  glEnable(GL_SCISSOR_TEST);
  glScissor(0, kH - 2, kW, 2);
  glClearColor(1, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glScissor(0, 0, 1, kH);
  glClearColor(0, 1, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  glDisable(GL_SCISSOR_TEST);
  std::vector<std::uint8_t> px;
  t->read_rgba(px);
  ASSERT_EQ(px.size(), std::size_t{kW * kH * 4});
  auto at = [&](int u, int v, int c) { return px[(static_cast<std::size_t>(v) * kW + u) * 4 + c]; };
  EXPECT_EQ(at(3, 0, 0), 255);  // top rows red
  EXPECT_EQ(at(3, 1, 0), 255);
  EXPECT_EQ(at(3, 2, 2), 255);  // below: blue
  EXPECT_EQ(at(3, kH - 1, 2), 255);
  EXPECT_EQ(at(0, 3, 1), 255);  // left column green
  EXPECT_EQ(at(1, 3, 2), 255);
  EXPECT_EQ(gl_error_message("readback"), "");
}

// Shared mode (the live display's): a context on another context's display
// sees its objects; the display is not terminated by the shared one; a
// missing share context is a clear error.
TEST(EglContext, SharedContextSeesTheOthersObjects) {
  DENTAR_GL_TEST_CONTEXT();
  {
    auto a = EglContext::create();
    ASSERT_TRUE(a.ok()) << a.error();
    GLuint tex = 0;
    glGenTextures(1, &tex);
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, 4, 4);
    glBindTexture(GL_TEXTURE_2D, 0);
    glFinish();
    EglContextOptions o;
    o.share_display = a->native_display();
    o.share_context = a->native_context();
    {
      auto b = EglContext::create(o);
      ASSERT_TRUE(b.ok()) << b.error();
      EXPECT_TRUE(b->shared());
      EXPECT_NE(b->description().find("shared"), std::string::npos) << b->description();
      EXPECT_TRUE(glIsTexture(tex)) << "the shared context does not see the first one's texture";
      auto c = EglContext::create();  // not shared: its own display and names
      ASSERT_TRUE(c.ok()) << c.error();
      EXPECT_FALSE(c->shared());
      EXPECT_FALSE(glIsTexture(tex));
    }
    // The first context still works after the shared one is gone.
    ASSERT_TRUE(a->make_current().ok());
    EXPECT_TRUE(glIsTexture(tex));
    glDeleteTextures(1, &tex);
    o.share_context = nullptr;
    auto bad = EglContext::create(o);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().find("share_context"), std::string::npos) << bad.error();
  }
  ASSERT_TRUE(test::gl_test_context().context->make_current().ok());
}

TEST(RenderTarget, RejectsImpossibleSize) {
  DENTAR_GL_TEST_CONTEXT();
  auto t = RenderTarget::create(0, 480);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.error().find("0x480"), std::string::npos) << t.error();
}

}  // namespace
}  // namespace dentar::ar
