// End to end (issue 25): `dentar assess` on a kinematics-only cohort with
// personal style, through the import; --cv subject and --cv trial with the
// person-identification check; bad column maps and a fold missing a class
// give exit code 2 and a message naming the file and the key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>

#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using dentar::test::CommandResult;

using dentar::test::run_dentar;

const fs::path& cohort() {
  static const fs::path dir = [] {
    const fs::path d = dentar::test::temp_dir("cli_assess_cohort");
    const CommandResult r = run_dentar("assess --generate " + d.string() +
                                " --kinematics-only --experts 3 --novices 3 --trials 2 --voxel-mm 0.25 --seed 4");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("generated 12 kinematics tables"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("personal style 1"), std::string::npos) << r.out;
    return d;
  }();
  return dir;
}

std::string kin(const std::string& trials = "trials.csv", const std::string& map = "columns.json") {
  return "assess --kinematics " + (cohort() / trials).string() + " --columns " + (cohort() / map).string();
}

TEST(CliAssess, LeaveOnePersonOutAndLeaveATrialOutWithIdentity) {
  CommandResult r = run_dentar(kin() + " --cv subject --method skill");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("method skill, leave-one-subject-out: accuracy"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("person identification with the same features and method"), std::string::npos) << r.out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(accuracy ([0-9.]+) % \((\d+)/12\))"))) << r.out;
  EXPECT_GE(std::stoi(m[2]), 8) << r.out;  // chance 6 of 12
  r = run_dentar(kin() + " --cv trial --method time");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("leave-one-trial-out"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("can measure who is operating"), std::string::npos) << r.out;
  r = run_dentar("assess --train " + cohort().string() + " --cv subject");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("use --kinematics"), std::string::npos) << r.out;
}

TEST(CliAssess, BadMapsAndAFoldWithoutAClassNameTheFileAndKey) {
  dentar::test::write_file(cohort() / "unknown.json", R"({"rate_hz": 100, "position": [2, 3, 4], "colour": 1})");
  CommandResult r = run_dentar(kin("trials.csv", "unknown.json") + " --cv subject");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("unknown.json: unknown key 'colour'"), std::string::npos) << r.out;
  dentar::test::write_file(cohort() / "list.json", R"({"time": ["t_s"], "position": [2, 3, 4]})");
  r = run_dentar(kin("trials.csv", "list.json") + " --cv subject");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("list.json: field 'time': one column is expected"), std::string::npos) << r.out;
  // One novice relabelled "intermediate": leaving that person out leaves no intermediate to train on.
  std::ifstream in(cohort() / "trials.csv");
  std::ofstream out(cohort() / "trials3.csv");
  for (std::string line; std::getline(in, line);) {
    if (line.find(",N3,") != std::string::npos) line = std::regex_replace(line, std::regex("novice$"), "intermediate");
    out << line << "\n";
  }
  out.close();
  r = run_dentar(kin("trials3.csv") + " --cv subject --method skill");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("trials3.csv: cross-validation: label 'intermediate': leaving out person N3"), std::string::npos)
      << r.out;
  r = run_dentar(kin() + " --cv banana");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--cv: 'banana' is not a mode"), std::string::npos) << r.out;
}

}  // namespace
