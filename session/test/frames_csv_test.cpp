// frames.csv's one writer and reader: the state names (one table, the
// tracker's enum), a live-recording row read back by the replay's reader,
// and the offline layout's header and row widths; both layouts read back as
// mirror use's camera frames (read_view_frames), and their errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "dentar/session/frames_csv.h"
#include "dentar/session/recording_table.h"
#include "testutil.h"

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

// Stereo runs (issue 28): three columns appended, the mono layout otherwise unchanged.
TEST(FramesCsv, StereoRowsAppendTheEyesAfterTheMonoColumns) {
  const std::string mono = offline_csv_header(), stereo = offline_csv_header(true);
  ASSERT_EQ(stereo.rfind(mono.substr(0, mono.size() - 1), 0), 0u) << stereo;
  EXPECT_EQ(stereo.substr(mono.size() - 1),
            ",eyes,man_views,mirror_views,right_composited,right_overlay,right_mirror_drawn,right_composite_ms,"
            "right_tooth_err_px,right_silhouette_iou\n");
  OfflineFrameRow r;
  r.man_state = 0;
  r.eyes = ar::FrameRecord::kEyesLeft;
  r.man_views = 1;
  const std::string row = offline_csv_row(r, true);
  EXPECT_EQ(cells(row), cells(stereo));
  EXPECT_NE(row.find(",left,1,0,0,0,0,,,\n"), std::string::npos) << row;  // no right eye's composite
  r.eyes = ar::FrameRecord::kEyesBoth;
  r.right_composited = r.right_overlay = true;
  r.right_composite_ms = 4.5;
  r.right_tooth_err_px = 0.25;
  r.right_iou = 0.96;
  const std::string both = offline_csv_row(r, true);
  EXPECT_EQ(cells(both), cells(stereo));
  EXPECT_NE(both.find(",both,1,0,1,1,0,4.5,0.25,0.96\n"), std::string::npos) << both;
  r.eyes = ar::FrameRecord::kEyesLeft;
  EXPECT_EQ(cells(offline_csv_row(r)), cells(mono));
  ar::FrameRecord fr;
  fr.eyes = ar::FrameRecord::kEyesBoth;
  const std::string live = recording_csv_row(fr, 0, 1.0, 0, true);
  EXPECT_EQ(cells(live), cells(recording_csv_header(true)));
  EXPECT_NE(live.find(",both,0,0,0,0\n"), std::string::npos) << live;
  fr.right.composited = fr.right.overlay = true;
  fr.right.composite_ms = 6.25;
  const std::string live_r = recording_csv_row(fr, 0, 1.0, 0, true);
  EXPECT_NE(live_r.find(",both,1,1,0,6.25\n"), std::string::npos) << live_r;
  EXPECT_EQ(recording_csv_header(true),
            recording_csv_header().substr(0, recording_csv_header().size() - 1) +
                ",eyes,right_composited,right_overlay,right_mirror_drawn,right_composite_ms\n");
  EXPECT_STREQ(eyes_name(ar::FrameRecord::kEyesRight), "right");
  EXPECT_STREQ(eyes_name(ar::FrameRecord::kEyesMono), "");
}

std::string temp_file(const std::string& name, const std::string& text) {
  const auto dir = dentar::test::temp_dir("frames_csv_" + name);
  std::filesystem::create_directories(dir);
  const auto p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

TEST(FramesCsv, ViewFramesFromTheOfflineLayout) {
  const std::string head =
      "frame,time_s,man_state,man_tx_mm,man_ty_mm,man_tz_mm,man_qw,man_qx,man_qy,man_qz,man_rms_px,man_tags,"
      "mirror_state,mirror_tx_mm,mirror_ty_mm,mirror_tz_mm,mirror_qw,mirror_qx,mirror_qy,mirror_qz,mirror_tags,"
      "tags_detected,full_frame,haptic_step,pedal\n";
  const std::string path = temp_file("offline.csv", head +
                                                        "0,0,tracking,1,2,300,1,0,0,0,0.3,4,lost,,,,,,,,0,4,1,33,0\n"
                                                        "1,0.033,predicted,1,2,300,0,1,0,0,0.3,4,tracking,5,6,250,1,0,0,0,1,5,0,66,1\n");
  auto f = read_view_frames(path, 1000);
  ASSERT_TRUE(f.ok()) << f.error();
  ASSERT_EQ(f->size(), 2u);
  EXPECT_NEAR((*f)[0].session_s, 0.033, 1e-12);
  EXPECT_FALSE((*f)[0].pedal);
  ASSERT_TRUE((*f)[0].T_cam_man.has_value());
  EXPECT_NEAR(((*f)[0].T_cam_man->translation() - Eigen::Vector3d(1e-3, 2e-3, 0.3)).norm(), 0, 1e-12);
  EXPECT_FALSE((*f)[0].T_cam_mtag.has_value());
  EXPECT_TRUE((*f)[1].pedal);
  ASSERT_TRUE((*f)[1].T_cam_mtag.has_value());
  // Quaternion (0, 1, 0, 0): 180 degrees about x.
  EXPECT_NEAR((*f)[1].T_cam_man->linear()(1, 1), -1.0, 1e-12);

  const std::string bad = temp_file("bad.csv", head + "0,0,tracking,1,abc,300,1,0,0,0,0.3,4,lost,,,,,,,,0,4,1,33,0\n");
  auto e = read_view_frames(bad, 1000);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().find("bad.csv: line 2, column 5 (man_ty_mm): 'abc' is not a number"), std::string::npos) << e.error();
  auto m = read_view_frames(temp_file("other.csv", "a,b,c\n1,2,3\n"), 1000);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().find("other.csv: line 1: not a frames.csv"), std::string::npos) << m.error();
}

TEST(FramesCsv, ViewFramesFromTheLiveLayout) {
  const std::string head =
      "frame,time_s,steady_s,source_index,haptic_steps,man_state,mirror_state,pen_state,man_T,mirror_T,pedal,force_N\n";
  const std::string path =
      temp_file("live.csv", head + "0,0,0,0,500,tracking,tracking,lost,1 0 0 0.01 0 1 0 0.02 0 0 1 0.3,"
                                   "1 0 0 0 0 1 0 0 0 0 1 0.25,1,0.5\n"
                                   "1,0.03,0.03,1,530,lost,lost,lost,,,0,0\n"
                                   "2,0.06,0.06,2,560,tracking,lost,lost,1 0 0 0");  // cut short by a crash: ends the table
  auto f = read_view_frames(path, 1000);
  ASSERT_TRUE(f.ok()) << f.error();
  ASSERT_EQ(f->size(), 2u);
  EXPECT_NEAR((*f)[0].session_s, 0.5, 1e-12);
  EXPECT_NEAR((*f)[0].T_cam_man->translation().z(), 0.3, 1e-12);
  EXPECT_NEAR((*f)[0].T_cam_mtag->translation().z(), 0.25, 1e-12);
  EXPECT_FALSE((*f)[1].T_cam_man.has_value());
  const std::string bad = temp_file("live_bad.csv", head + "0,0,0,0,500,tracking,lost,lost,1 0 0,,1,0.5\n");
  auto e = read_view_frames(bad, 1000);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().find("live_bad.csv: line 2, column 9 (man_T): expected 12 numbers"), std::string::npos) << e.error();
}

}  // namespace
}  // namespace dentar::session
