// RAII wrapper of a dlopen()ed vendor runtime, and symbol lookup that
// reports what is missing instead of crashing on a null function pointer.
#pragma once

#include <dlfcn.h>
#include <link.h>

#include <climits>
#include <cstdlib>
#include <string>
#include <utility>

namespace dentar::haptics::detail {

class DlLibrary {
 public:
  DlLibrary() = default;
  ~DlLibrary() { reset(); }
  DlLibrary(const DlLibrary&) = delete;
  DlLibrary& operator=(const DlLibrary&) = delete;
  DlLibrary(DlLibrary&& o) noexcept : h_(std::exchange(o.h_, nullptr)), name_(std::move(o.name_)) {}
  DlLibrary& operator=(DlLibrary&& o) noexcept {
    if (this != &o) {
      reset();
      h_ = std::exchange(o.h_, nullptr);
      name_ = std::move(o.name_);
    }
    return *this;
  }

  // Loads `name` (a file name searched by the loader, or a path). On failure
  // returns false and sets `error` to dlerror()'s text.
  bool open(const std::string& name, std::string& error) {
    reset();
    dlerror();
    h_ = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h_) {
      const char* e = dlerror();
      error = e ? e : ("cannot load " + name);
      return false;
    }
    name_ = name;
    return true;
  }
  void reset() {
    if (h_) dlclose(h_);
    h_ = nullptr;
  }
  bool loaded() const { return h_ != nullptr; }
  const std::string& name() const { return name_; }

  // The file actually loaded (symlinks resolved), or the requested name.
  std::string path() const {
    if (!h_) return {};
    link_map* lm = nullptr;
    if (dlinfo(h_, RTLD_DI_LINKMAP, &lm) != 0 || !lm || !lm->l_name) return name_;
    char buf[PATH_MAX];
    if (realpath(lm->l_name, buf)) return buf;
    return lm->l_name;
  }

  // Typed symbol lookup; null when absent.
  template <typename F>
  bool sym(const char* name, F& out) const {
    out = h_ ? reinterpret_cast<F>(dlsym(h_, name)) : nullptr;
    return out != nullptr;
  }

 private:
  void* h_ = nullptr;
  std::string name_;
};

// "libHD.so.3.4.0" -> "3.4.0"; "" when the file name carries no version.
inline std::string version_from_filename(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const std::string file = slash == std::string::npos ? path : path.substr(slash + 1);
  const auto so = file.find(".so.");
  return so == std::string::npos ? std::string() : file.substr(so + 4);
}

// Environment override or default.
inline std::string library_or_env(const std::string& requested, const char* env,
                                  const char* fallback) {
  if (!requested.empty()) return requested;
  if (const char* e = std::getenv(env); e && *e) return e;
  return fallback;
}

inline double monotonic_s() noexcept {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace dentar::haptics::detail
