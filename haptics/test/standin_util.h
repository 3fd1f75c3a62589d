// Test helpers: load the stand-in vendor runtimes (built in the test tree)
// and reach their standin_* control functions.
#pragma once

#include <dlfcn.h>
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>

namespace dentar::haptics::standin {

inline std::string hd_path() { return std::string(DENTAR_STANDIN_DIR) + "/libHD.so"; }
inline std::string dhd_path() { return std::string(DENTAR_STANDIN_DIR) + "/libdhd.so"; }

// Holds the stand-in loaded for the whole test binary (so its state is
// shared with the backend, which loads the same file) and looks up control
// functions by name.
class Lib {
 public:
  explicit Lib(const std::string& path) : h_(dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL)) {}
  ~Lib() {
    if (h_) dlclose(h_);
  }
  bool ok() const { return h_ != nullptr; }
  template <typename F>
  F fn(const char* name) const {
    auto f = reinterpret_cast<F>(dlsym(h_, name));
    EXPECT_NE(f, nullptr) << name;
    return f;
  }

 private:
  void* h_;
};

// Polls `cond` every 0.2 ms for up to `timeout_s`; true once it holds. The
// limit only bounds a failure (a loaded CI machine under TSan is slow to
// start threads); a passing test returns as soon as `cond` holds.
template <typename C>
bool wait_for(C cond, double timeout_s = 10.0) {
  const auto t0 = std::chrono::steady_clock::now();
  while (!cond()) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > timeout_s)
      return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

}  // namespace dentar::haptics::standin
