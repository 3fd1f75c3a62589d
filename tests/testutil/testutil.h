// Test utilities shared by all modules' tests.
#pragma once

#include <filesystem>
#include <string>

namespace dentar::test {

// ../shared/data beside the project root, or empty when absent. Tests that
// need it call GTEST_SKIP() with a message when this is empty.
std::filesystem::path shared_data_dir();

// A fresh, empty temporary directory unique to the calling test. All of a
// process's are removed at exit, unless a test failed or DENTAR_KEEP_TMP is set.
std::filesystem::path temp_dir(const std::string& name);

// Whole file as bytes/text (empty on failure).
std::string read_file(const std::filesystem::path& p);
void write_file(const std::filesystem::path& p, const std::string& bytes);

// Runs a shell command, capturing stdout and stderr together. code is the
// exit status, -1 when the command could not run or was killed.
struct CommandResult {
  int code = -1;
  std::string out;
};
CommandResult run_command(const std::string& command);

#ifdef DENTAR_BINARY
// `dentar ARGS` with the binary the calling test target was built against
// (DENTAR_BINARY is a per-target define, so this is inline here).
inline CommandResult run_dentar(const std::string& args) { return run_command(std::string(DENTAR_BINARY) + " " + args); }
#endif

}  // namespace dentar::test
