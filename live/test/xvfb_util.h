// Shared by the tests that run `dentar` windows under Xvfb (live,
// calibrate live, station health): skip cleanly without xvfb-run, unless
// DENTAR_REQUIRE_GL says the machine must have it (CI).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace dentar::test {

inline bool have_xvfb() { return std::system("command -v xvfb-run >/dev/null 2>&1") == 0; }

// `cmd` under a fresh X server (-a: a free display number, so parallel tests
// do not collide), 1280x1024 24-bit.
inline std::string xvfb(const std::string& cmd) { return "xvfb-run -a -s '-screen 0 1280x1024x24' " + cmd; }

// A JSON file the program wrote; a missing or unreadable file names itself.
inline nlohmann::json read_json(const std::filesystem::path& p) {
  std::ifstream f(p);
  if (!f) throw std::runtime_error("cannot read " + p.string());
  return nlohmann::json::parse(f);
}

}  // namespace dentar::test

#define REQUIRE_XVFB()                                                                        \
  do {                                                                                        \
    if (!dentar::test::have_xvfb()) {                                                         \
      if (std::getenv("DENTAR_REQUIRE_GL")) FAIL() << "xvfb-run missing (apt install xvfb)";  \
      GTEST_SKIP() << "xvfb-run not installed (Debian package xvfb)";                         \
    }                                                                                         \
  } while (0)
