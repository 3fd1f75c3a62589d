// `dentar live --stylus sim --exercise X --hand-skill S --hand-style G --hand-seed N` as a user
// runs it under Xvfb: the simulated person works the whole exercise, the run stops by itself
// when the hand has finished, and the session is recorded and scored. Label `long` (about 30 s:
// the class I cavity's styled expert script runs 19 s of engine time in real time).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "testutil.h"
#include "xvfb_util.h"

namespace fs = std::filesystem;
using dentar::test::read_json;
using dentar::test::run_command;
using dentar::test::xvfb;

namespace {

const std::string kBin = DENTAR_BINARY;

TEST(LiveHandXvfb, TheSimulatedPersonFinishesTheExerciseAndTheRunStops) {
  REQUIRE_XVFB();
  const fs::path t = dentar::test::temp_dir("live_hand");
  auto r = run_command(kBin + " synth --preset standard --frames 30 --resolution 640x480 --seed 3 --webcam --out " +
                       (t / "clip").string() + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path rec = t / "rec";
  r = run_command(xvfb(kBin + " live --camera live:" + (t / "clip" / "camera.avi").string() + " --station " +
                       (t / "clip" / "station.json").string() +
                       " --loop --stylus sim --exercise molar_class1_cavity --hand-skill 1 --hand-style 1 --hand-seed 8"
                       " --no-hud --engine-cpu -1 --seconds 300 --record " + rec.string() + " --summary " +
                       (t / "live.json").string() + " 2>&1"));
  ASSERT_EQ(r.code, 0) << r.out;
  // The hand's script length is said at the start, and the run ends when the engine has
  // stepped through it (not at the 300 s bound).
  const auto pos = r.out.find("works the exercise for ");
  ASSERT_NE(pos, std::string::npos) << r.out;
  const double script_s = std::stod(r.out.substr(pos + 23));
  EXPECT_GT(script_s, 5.0);
  const auto sum = read_json(t / "live.json");
  EXPECT_EQ(sum["stop_reason"], "the simulated hand finished the exercise") << sum.dump(2);
  const double steps = sum["engine"]["steps"].get<double>();
  EXPECT_GE(steps, 1000.0 * script_s) << sum.dump(2);
  EXPECT_LT(steps, 1000.0 * (script_s + 30.0)) << sum.dump(2);
  const auto meta = read_json(rec / "recording.json");
  EXPECT_EQ(meta["stop_reason"], "the simulated hand finished the exercise");
  EXPECT_EQ(meta["hand"]["skill"].get<double>(), 1.0);
  EXPECT_EQ(meta["hand"]["style"].get<double>(), 1.0);
  EXPECT_EQ(meta["hand"]["seed"].get<int>(), 8);
  // Scored against the exercise, with what was cut.
  ASSERT_TRUE(fs::exists(rec / "score.json")) << r.out;
  const auto score = read_json(rec / "score.json");
  EXPECT_EQ(score["exercise"]["name"], "molar_class1_cavity");
  EXPECT_GT(score["outcome"]["removed_total_mm3"].get<double>(), 1.0) << score["outcome"].dump(2);
}

}  // namespace
