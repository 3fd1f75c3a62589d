// End to end: `dentar assess` generates a cohort, cross-validates, saves and
// applies a model; `dentar score` scores a session folder and a .dlog, writes
// the HTML report and the JSON summary, and handles damaged logs and bad
// arguments with clear messages.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using dentar::test::CommandResult;

using dentar::test::run_dentar;

// One small cohort shared by the tests (2 experts, 2 novices, 1 trial, coarse tooth).
const fs::path& cohort() {
  static const fs::path dir = [] {
    const fs::path d = dentar::test::temp_dir("cli_score_cohort");
    const CommandResult r = run_dentar("assess --generate " + d.string() +
                                " --experts 2 --novices 2 --trials 1 --voxel-mm 0.25 --seed 3");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("generated 4 sessions"), std::string::npos) << r.out;
    return d;
  }();
  return dir;
}

TEST(CliScore, HelpHasSynopsisAndExample) {
  for (const char* sub : {"score", "assess"}) {
    const CommandResult r = run_dentar(std::string(sub) + " --help");
    EXPECT_EQ(r.code, 0) << sub;
    EXPECT_NE(r.out.find("Synopsis"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Example"), std::string::npos) << r.out;
  }
}

TEST(CliScore, ScoresASessionFolderAndWritesReportAndSummary) {
  const fs::path s = cohort() / "N1_t1";
  const CommandResult r = run_dentar("score " + s.string() + " --reference-trials 1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("/ 18 points"), std::string::npos) << r.out;
  const std::string html = dentar::test::read_file(s / "score.html");
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_NE(html.find("Target map against the cut"), std::string::npos);
  EXPECT_NE(html.find("Fz long axis"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);  // self-contained, static
  const auto j = nlohmann::json::parse(dentar::test::read_file(s / "score.json"));
  EXPECT_EQ(j["outcome"]["max_points"], 18.0);
  EXPECT_EQ(j["outcome"]["criteria"].size(), 6u);
  EXPECT_EQ(j["steps"].size(), 4u);
  EXPECT_GT(j["outcome"]["removed_total_mm3"].get<double>(), 1.0);
  EXPECT_FALSE(j["feedback"].empty());
  // A .dlog path directly, output elsewhere.
  const fs::path out = dentar::test::temp_dir("cli_score_out");
  const CommandResult r2 = run_dentar("score " + (s / "session.dlog").string() + " --out " + out.string() + " --quiet");
  ASSERT_EQ(r2.code, 0) << r2.out;
  EXPECT_TRUE(fs::exists(out / "score.html"));
}

TEST(CliScore, CrossValidationModelAndClassification) {
  const fs::path m = cohort() / "model.json";
  CommandResult r = run_dentar("assess --train " + cohort().string() + " --cv subject --method ghmm --states 3 --save " + m.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("leave-one-subject-out: accuracy"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("95 % CI"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("confusion"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(m));
  r = run_dentar("assess --model " + m.string() + " " + (cohort() / "E1_t1").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(r.out.find(": expert") != std::string::npos || r.out.find(": novice") != std::string::npos) << r.out;
}

TEST(CliScore, DamagedLogsAndBadArguments) {
  const fs::path d = dentar::test::temp_dir("cli_score_bad");
  const std::string bytes = dentar::test::read_file(cohort() / "E2_t1" / "session.dlog");
  ASSERT_GT(bytes.size(), 5000u);
  for (const char* sub : {"cut", "head", "k"}) fs::create_directories(d / sub);
  // Cut inside the last block: the good blocks are scored, with a warning.
  dentar::test::write_file(d / "cut" / "session.dlog", bytes.substr(0, bytes.size() - 700));
  CommandResult r = run_dentar("score " + (d / "cut").string() + " --reference-trials 1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("warning"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("byte offset"), std::string::npos) << r.out;
  // Cut inside the header: an error naming the file.
  dentar::test::write_file(d / "head" / "session.dlog", bytes.substr(0, 30));
  r = run_dentar("score " + (d / "head").string());
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find((d / "head" / "session.dlog").string()), std::string::npos) << r.out;
  r = run_dentar("score /nonexistent/session");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("no such file or folder"), std::string::npos) << r.out;
  r = run_dentar("score " + (cohort() / "E1_t1").string() + " --exercise incisor_partial_crown");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("drilled on a molar"), std::string::npos) << r.out;
  r = run_dentar("score " + (cohort() / "E1_t1").string() + " --exercise no_such_exercise");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("no built-in exercise 'no_such_exercise'"), std::string::npos) << r.out;
  r = run_dentar("assess --train " + cohort().string() + " --cv subject --method svm");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("unknown method 'svm'"), std::string::npos) << r.out;
  r = run_dentar("assess");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("nothing to do"), std::string::npos) << r.out;
  r = run_dentar("assess --separation 3 --generate " + d.string());
  EXPECT_EQ(r.code, 2);
  dentar::test::write_file(d / "k" / "trials.csv", "file,subject,trial,label\na.csv,S1,1,expert\n");
  dentar::test::write_file(d / "k" / "a.csv", "t,x,y,z\n0,1,2,3\n1,1,2\n");
  dentar::test::write_file(d / "k" / "map.json", R"({"time":"t","position":["x","y","z"]})");
  r = run_dentar("assess --kinematics " + (d / "k" / "trials.csv").string() + " --columns " + (d / "k" / "map.json").string() +
          " --cv subject");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("a.csv: line 3: 3 columns, expected 4"), std::string::npos) << r.out;
}

}  // namespace
