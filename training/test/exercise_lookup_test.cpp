// Where a built-in exercise comes from (session 22): DENTAR_ASSETS, else the source tree's
// assets compiled in; never the working directory's assets/exercises, which made a command
// started in another checkout (score_rank_bench from a worktree) score that copy silently.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "dentar/training/exercise.h"
#include "testutil.h"

namespace dentar::training {
namespace {
namespace fs = std::filesystem;

// DENTAR_ASSETS and the working directory set for one test, restored after.
class Lookup : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const char* e = std::getenv("DENTAR_ASSETS")) saved_env_ = e;
    ::unsetenv("DENTAR_ASSETS");
    saved_cwd_ = fs::current_path();
    dir_ = test::temp_dir("exercise_lookup");
    // A decoy copy of a built-in exercise under <dir>/assets/exercises, another title.
    const std::string real = builtin_exercise_dir() + "/molar_class1_cavity.json";
    std::ifstream in(real);
    ASSERT_TRUE(in) << real;
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string from = "\"title\": \"", to = "\"title\": \"DECOY ";
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, from.size(), to);
    fs::create_directories(dir_ / "assets" / "exercises");
    std::ofstream(dir_ / "assets" / "exercises" / "molar_class1_cavity.json") << text;
  }
  void TearDown() override {
    fs::current_path(saved_cwd_);
    if (saved_env_) ::setenv("DENTAR_ASSETS", saved_env_->c_str(), 1);
    else ::unsetenv("DENTAR_ASSETS");
  }
  std::optional<std::string> saved_env_;
  fs::path saved_cwd_, dir_;
};

TEST_F(Lookup, TheWorkingDirectorysAssetsAreNotUsed) {
  const std::string compiled = builtin_exercise_dir();
  fs::current_path(dir_);
  EXPECT_EQ(builtin_exercise_dir(), compiled);
  auto ex = load_named_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  EXPECT_EQ(ex->title.rfind("DECOY", 0), std::string::npos) << ex->source;
  EXPECT_EQ(ex->source, compiled + "/molar_class1_cavity.json");
}

TEST_F(Lookup, DentarAssetsComesFirst) {
  ::setenv("DENTAR_ASSETS", (dir_ / "assets").c_str(), 1);
  auto ex = load_named_exercise("molar_class1_cavity");
  ASSERT_TRUE(ex.ok()) << ex.error();
  EXPECT_EQ(ex->title.rfind("DECOY", 0), 0u) << ex->source;
  EXPECT_EQ(ex->source, (dir_ / "assets" / "exercises" / "molar_class1_cavity.json").string());
}

}  // namespace
}  // namespace dentar::training
