// frames.csv's one writer and reader: the state names (one table, the
// tracker's enum), a live-recording row read back by the replay's reader,
// and the offline layout's header and row widths.
#include <gtest/gtest.h>

#include <sstream>

#include "dentar/session/frames_csv.h"
#include "dentar/session/recording_table.h"

namespace dentar::session {
namespace {

std::size_t cells(const std::string& line) {
  std::size_t n = 1;
  for (char c : line) n += c == ',' ? 1 : 0;
  return n;
}

TEST(FramesCsv, StateNamesRoundTripThroughTheEnum) {
  for (TrackState s : {TrackState::kTracking, TrackState::kPredicted, TrackState::kLost}) {
    auto p = parse_state(state_name(s));
    ASSERT_TRUE(p) << p.error();
    EXPECT_EQ(*p, s);
    EXPECT_STREQ(state_name(static_cast<int>(s)), state_name(s));
  }
  EXPECT_STREQ(state_name(0), "tracking");
  EXPECT_STREQ(state_name(1), "predicted");
  EXPECT_STREQ(state_name(2), "lost");
  EXPECT_STREQ(state_name(7), "lost");  // out of range: never a pose
  const auto bad = parse_state("tracked");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().find("\"tracked\""), std::string::npos) << bad.error();
}

TEST(FramesCsv, RecordingRowsReadBackAsTheReplayReadsThem) {
  std::string csv = recording_csv_header();
  ar::FrameRecord a, b;
  a.time_s = 0.0;
  a.haptic_steps_done = 0;
  a.man_state = 2;  // lost: no pose cell
  a.pose_step = -1;
  a.disc_start = true;  // a tag search starts on frame 0 ...
  b.time_s = 1.0 / 30.0;
  b.haptic_steps_done = 34;
  b.man_state = 0;
  b.mir_state = 1;
  b.T_cam_man.translation() = Eigen::Vector3d(0.01, -0.02, 0.35);
  b.pose_step = 27.25;
  b.disc_merged = 0;  // ... and is merged on frame 1
  csv += recording_csv_row(a, 0, 100.0, 0) + recording_csv_row(b, 1, 100.0 + 1.0 / 30.0, 2);
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  const std::size_t width = cells(line);
  while (std::getline(lines, line)) EXPECT_EQ(cells(line), width) << line;
  EXPECT_NE(csv.find(",lost,lost,lost,,,"), std::string::npos) << csv;  // lost: empty pose cells
  EXPECT_NE(csv.find(",tracking,predicted,lost,"), std::string::npos) << csv;

  std::istringstream in(csv);
  auto t = parse_recording_table(in, true, "rec/frames.csv");
  ASSERT_TRUE(t) << t.error();
  ASSERT_EQ(t->capture_s.size(), 2u);
  EXPECT_EQ(t->capture_s[1], 1.0 / 30.0);  // 17 digits: the same double
  EXPECT_EQ(t->haptic_steps[1], 34u);
  ASSERT_EQ(t->pose_step.size(), 2u);
  EXPECT_EQ(t->pose_step[0], -1.0);
  EXPECT_EQ(t->pose_step[1], 27.25);
  ASSERT_EQ(t->cues.size(), 2u);
  EXPECT_TRUE(t->cues[0].start);
  EXPECT_EQ(t->cues[1].merge, 0);
  EXPECT_TRUE(t->cues_exact);
  EXPECT_FALSE(t->truncated);
}

TEST(FramesCsv, OfflineRowsAreAsWideAsTheHeader) {
  const std::string head = offline_csv_header();
  OfflineFrameRow lost, tracked;
  tracked.man_state = 0;
  tracked.mir_state = 1;
  tracked.man_err_mm = 0.25;
  const std::string r1 = offline_csv_row(lost), r2 = offline_csv_row(tracked);
  EXPECT_EQ(cells(r1), cells(head));
  EXPECT_EQ(cells(r2), cells(head));
  EXPECT_EQ(r1.rfind("0,0,lost,,,,,,,,", 0), 0u) << r1;
  EXPECT_NE(r2.find(",tracking,"), std::string::npos) << r2;
  EXPECT_NE(r2.find(",predicted,"), std::string::npos) << r2;
}

}  // namespace
}  // namespace dentar::session
