// frames.csv of a live recording as `dentar offline` replays it: accepted
// tables, a row cut by a crash, and bad values refused with the line, the
// column and what is wrong.
#include <gtest/gtest.h>

#include <sstream>

#include "dentar/session/recording_table.h"

#include "dentar/ar/frame_pipeline.h"

namespace dentar::session {
namespace {

const char* kHeader = "frame,time_s,steady_s,haptic_steps,man_state,disc_start,disc_merged\n";

Result<RecordingTable> parse(const std::string& body, bool async = true) {
  std::istringstream in(kHeader + body);
  return parse_recording_table(in, async, "rec/frames.csv");
}

TEST(RecordingTable, ReadsTimesStepsAndCues) {
  auto r = parse("0,0,5.0,0,lost,1,-1\n1,0.033,5.033,33,tracking,0,0\n2,0.067,5.067,66,tracking,1,-1\n"
                 "3,0.1,5.1,99,tracking,0,2\n");
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->capture_s.size(), 4u);
  EXPECT_DOUBLE_EQ(r->capture_s[1], 0.033);
  EXPECT_EQ(r->haptic_steps[3], 99u);
  ASSERT_EQ(r->cues.size(), 4u);
  EXPECT_TRUE(r->cues[0].start);
  EXPECT_EQ(r->cues[1].merge, 0);
  EXPECT_EQ(r->cues[3].merge, 2);
  EXPECT_TRUE(r->cues_exact);
  EXPECT_FALSE(r->truncated);
  // Inline discovery: no cues, and the disc_ columns are not needed.
  std::istringstream in("frame,time_s,haptic_steps\n0,0,0\n1,0.033,33\n");
  auto i = parse_recording_table(in, false, "x.csv");
  ASSERT_TRUE(i) << i.error();
  EXPECT_TRUE(i->cues.empty());
}

TEST(RecordingTable, ARowCutByACrashIsDroppedTheRestReplays) {
  auto r = parse("0,0,5.0,0,lost,1,-1\n1,0.033,5.033,33,tracking,0,0\n2,0.06");
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->capture_s.size(), 2u);
  EXPECT_TRUE(r->truncated);
  // Cut inside a number of a needed column: still only the complete rows.
  r = parse("0,0,5.0,0,lost,1,-1\n1,0.033,5.033,3");
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->capture_s.size(), 1u);
}

TEST(RecordingTable, AMergeOfASearchNotStartedIsDroppedAndMarked) {
  auto r = parse("0,0,5.0,0,lost,0,-1\n1,0.033,5.033,33,tracking,0,0\n");
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->cues[1].merge, -1);
  EXPECT_FALSE(r->cues_exact);
}

TEST(RecordingTable, BadValuesNameLineColumnAndWhy) {
  struct Case {
    std::string body, want;
  };
  const Case cases[] = {
      {"0,0,5,0,lost,1,-1\n1,0.03,5,-5,x,0,-1\n", "line 3, column haptic_steps: \"-5\" is not a step count"},
      {"0,0,5,0,lost,1,-1\n1,0.03,5,99999999999,x,0,-1\n", "line 3, column haptic_steps: \"99999999999\" is beyond"},
      {"0,0,5,40,lost,1,-1\n1,0.03,5,30,x,0,-1\n", "column haptic_steps: \"30\" goes back"},
      {"0,nan,5,0,lost,1,-1\n", "line 2, column time_s: \"nan\" is not a finite time"},
      {"0,0.5,5,0,lost,1,-1\n1,0.2,5,1,x,0,-1\n", "column time_s: \"0.2\" goes back in time"},
      {"0,0,5,0,lost,1,-1\n2,0.03,5,1,x,0,-1\n", "column frame: \"2\" follows frame 0: frames 1..1 are missing"},
      {"0,0,5,0,lost,1,-1\n0,0.03,5,1,x,0,-1\n", "column frame: \"0\" is out of order (expected frame 1)"},
      {"0x,0,5,0,lost,1,-1\n", "column frame: \"0x\" is not a frame number"},
      {"0,0,5,0,lost,2,-1\n", "column disc_start: \"2\" must be 0 or 1"},
      {"0,0,5,0,lost,1,0\n", "column disc_merged: \"0\" must be -1 or an earlier frame"},
      {"0,0,5,0,lost,1,-1\n1,0.03\n2,0.06,5,1,x,0,-1\n", "line 3: 2 fields, the header names 7"},
      {"", "rec/frames.csv: no frames recorded"},
  };
  for (const auto& c : cases) {
    auto r = parse(c.body);
    ASSERT_FALSE(r) << c.body;
    EXPECT_NE(r.error().find(c.want), std::string::npos) << r.error();
    EXPECT_EQ(r.error().rfind("rec/frames.csv: ", 0), 0u) << r.error();
  }
  std::istringstream no_disc("frame,time_s,haptic_steps\n0,0,0\n");
  auto r = parse_recording_table(no_disc, true, "f.csv");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().find("disc_start and disc_merged"), std::string::npos) << r.error();
  std::istringstream empty("");
  r = parse_recording_table(empty, false, "f.csv");
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error(), "f.csv: empty");
}

// Issue 24: the drawn stylus pose's step (dentar live's latency compensation), optional: older
// recordings have no column; -1 = the newest pose; a step after the row's haptic_steps (a pose
// the engine had not made yet) or a negative one is refused.
TEST(RecordingTable, PoseStepIsOptionalAndBounded) {
  std::istringstream in("frame,time_s,haptic_steps,pose_step\n0,0,10,-1\n1,0.033,43,9.25\n");
  auto r = parse_recording_table(in, false, "p.csv");
  ASSERT_TRUE(r) << r.error();
  ASSERT_EQ(r->pose_step.size(), 2u);
  EXPECT_EQ(r->pose_step[0], -1);
  EXPECT_DOUBLE_EQ(r->pose_step[1], 9.25);
  EXPECT_TRUE(parse("0,0,5.0,0,lost,1,-1\n")->pose_step.empty());
  for (const char* row : {"0,0,10,10.5\n", "0,0,10,-0.5\n", "0,0,10,x\n"}) {
    std::istringstream bad(std::string("frame,time_s,haptic_steps,pose_step\n") + row);
    auto b = parse_recording_table(bad, false, "p.csv");
    ASSERT_FALSE(b) << row;
    EXPECT_NE(b.error().find("column pose_step"), std::string::npos) << b.error();
  }
}

}  // namespace
}  // namespace dentar::session

// A stereo live run's table (issue 28: column eyes) from before the right eye was kept
// (recording.json without "stereo": frames/ holds the left eye only): refused, naming why,
// rather than replayed from one eye as if it were the run.
TEST(RecordingTable, AStereoRunIsNotReplayedFromOneEye) {
  std::istringstream in("frame,time_s,steady_s,source_index,haptic_steps,eyes\n0,0,1,0,1,both\n");
  auto r = dentar::session::parse_recording_table(in, false, "rec/frames.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("rec/frames.csv: line 1: a stereo run (column eyes)"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("frames_right"), std::string::npos) << r.error();
}

// A stereo run that kept both eyes: the eyes of each frame are read (both, or left: the
// right eye lost); the column is required, and any other value is refused by line and column.
TEST(RecordingTable, AStereoRunKeepsEachFramesEyes) {
  using dentar::ar::FrameRecord;
  std::istringstream in(
      "frame,time_s,steady_s,source_index,haptic_steps,eyes\n0,0,1,0,1,both\n1,0.1,1.1,1,90,left\n2,0.2,1.2,2,190,both\n");
  auto r = dentar::session::parse_recording_table(in, false, "rec/frames.csv", true);
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->eyes.size(), 3u);
  EXPECT_EQ(r->eyes[0], FrameRecord::kEyesBoth);
  EXPECT_EQ(r->eyes[1], FrameRecord::kEyesLeft);
  EXPECT_EQ(r->eyes[2], FrameRecord::kEyesBoth);
  std::istringstream mono("frame,time_s,haptic_steps\n0,0,1\n");
  auto m = dentar::session::parse_recording_table(mono, false, "rec/frames.csv", true);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("needs the column eyes"), std::string::npos) << m.error();
  std::istringstream odd("frame,time_s,haptic_steps,eyes\n0,0,1,both\n1,0.1,5,mono\n");
  auto b = dentar::session::parse_recording_table(odd, false, "rec/frames.csv", true);
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().find("line 3, column eyes: \"mono\" must be both, left or right"), std::string::npos) << b.error();
  // A mono table read as mono is unchanged: no eyes.
  std::istringstream plain("frame,time_s,haptic_steps\n0,0,1\n");
  auto p = dentar::session::parse_recording_table(plain, false, "rec/frames.csv");
  ASSERT_TRUE(p.ok()) << p.error();
  EXPECT_TRUE(p->eyes.empty());
}
