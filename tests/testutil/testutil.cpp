#include "testutil.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>

#include <fstream>
#include <sstream>

namespace dentar::test {

std::filesystem::path shared_data_dir() {
  namespace fs = std::filesystem;
  const fs::path p = fs::path(DENTAR_SOURCE_DIR) / ".." / "shared" / "data";
  std::error_code ec;
  if (fs::is_directory(p, ec)) return fs::weakly_canonical(p, ec);
  return {};
}

namespace {
// Every temp_dir of this process sits under one root. It is removed when the
// process exits, unless a test failed (left for inspection, path printed) or
// DENTAR_KEEP_TMP is set. Registered after gtest's UnitTest exists, so atexit
// runs this before gtest is torn down. Without it, each suite run left GBs in /tmp.
std::filesystem::path process_root() {
  static const std::filesystem::path root = [] {
    auto p = std::filesystem::temp_directory_path() / ("dentar_test_" + std::to_string(::getpid()));
    (void)::testing::UnitTest::GetInstance();
    std::atexit([] {
      namespace fs = std::filesystem;
      const auto r = fs::temp_directory_path() / ("dentar_test_" + std::to_string(::getpid()));
      const char* keep = std::getenv("DENTAR_KEEP_TMP");
      if ((keep && *keep) || ::testing::UnitTest::GetInstance()->Failed()) {
        std::fprintf(stderr, "test files kept in %s\n", r.c_str());
        return;
      }
      std::error_code ec;
      fs::remove_all(r, ec);
    });
    return p;
  }();
  return root;
}
}  // namespace

std::filesystem::path temp_dir(const std::string& name) {
  namespace fs = std::filesystem;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string tag = name;
  if (info) tag = std::string(info->test_suite_name()) + "_" + info->name() + "_" + name;
  for (char& c : tag)
    if (c == '/') c = '_';
  fs::path p = process_root() / tag;
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

std::string read_file(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

void write_file(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

CommandResult run_command(const std::string& command) {
  CommandResult r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace dentar::test
