// One headless EGL context per GL test binary. Tests call
// DENTAR_GL_TEST_CONTEXT() first: it skips the test with the EGL error when no
// EGL device exists at all, or fails it when DENTAR_REQUIRE_GL=1 (CI, so a
// broken Mesa cannot pass as "skipped").
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "dentar/ar/egl_context.h"

namespace dentar::ar::test {

struct GlTestContext {
  EglContext* context = nullptr;  // nullptr when creation failed
  std::string error;
};

// Created on first use on the test thread and deliberately never destroyed:
// tearing EGL down from a static destructor races the driver's own exit
// handlers, and the process ends right after anyway.
inline const GlTestContext& gl_test_context() {
  static const GlTestContext* ctx = [] {
    auto* c = new GlTestContext;
    auto r = EglContext::create();
    if (r) {
      c->context = new EglContext(std::move(r).value());
      std::printf("[ gl ] %s\n", c->context->description().c_str());
    } else {
      c->error = r.error();
    }
    return c;
  }();
  return *ctx;
}

inline bool gl_required() {
  const char* v = std::getenv("DENTAR_REQUIRE_GL");
  return v != nullptr && std::string(v) == "1";
}

}  // namespace dentar::ar::test

#define DENTAR_GL_TEST_CONTEXT()                                                    \
  do {                                                                              \
    const auto& gl_ctx_ = ::dentar::ar::test::gl_test_context();                    \
    if (gl_ctx_.context == nullptr) {                                               \
      if (::dentar::ar::test::gl_required()) FAIL() << gl_ctx_.error;               \
      GTEST_SKIP() << "no headless EGL context (set DENTAR_REQUIRE_GL=1 to fail): " \
                   << gl_ctx_.error;                                                \
    }                                                                               \
    ASSERT_TRUE(gl_ctx_.context->make_current().ok());                              \
  } while (0)
