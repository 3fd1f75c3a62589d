// recording.json as `dentar offline` reads it back (read_recording): how the live run tracked.
#include "dentar/session/recording.h"

#include <gtest/gtest.h>

#include <fstream>

#include "testutil.h"

namespace dentar::session {
namespace {

namespace fs = std::filesystem;

fs::path write_recording(const std::string& name, const std::string& meta_extra) {
  const fs::path d = test::temp_dir(name);
  std::ofstream(d / "recording.json") << R"({"format": "dentar-recording", "version": 1, "discovery": "inline")"
                                      << meta_extra << "}\n";
  std::ofstream(d / "frames.csv") << "frame,time_s,steady_s,haptic_steps,man_state\n0,0,5.0,0,lost\n1,0.033,5.033,33,tracking\n";
  return d;
}

// Issue 28 session 16: the prediction the live run drew with (--predict-ms) is read back, so a
// replay draws the same poses; older recordings have none (0); a bad value names the field.
TEST(Recording, PredictMsIsReadBackAndZeroWhenAbsent) {
  auto r = read_recording(write_recording("rec_predict", R"(, "predict_ms": 17.5)"));
  ASSERT_TRUE(r) << r.error();
  EXPECT_DOUBLE_EQ(r->predict_ms, 17.5);
  EXPECT_EQ(r->capture_s.size(), 2u);
  auto old = read_recording(write_recording("rec_old", ""));
  ASSERT_TRUE(old) << old.error();
  EXPECT_EQ(old->predict_ms, 0.0);
  for (const char* bad : {R"(, "predict_ms": -3)", R"(, "predict_ms": "17")", R"(, "predict_ms": 900)"}) {
    auto b = read_recording(write_recording("rec_bad", bad));
    ASSERT_FALSE(b) << bad;
    EXPECT_NE(b.error().find("predict_ms"), std::string::npos) << b.error();
  }
}

// Issue 28 session 18: how the live run decoded a Motion JPEG camera's frames, so the replay
// decodes the recording's .jpg files the same way; older recordings decoded to BGR.
TEST(Recording, JpegDecodeIsReadBackAndBgrWhenAbsent) {
  auto r = read_recording(write_recording("rec_jpeg", R"(, "jpeg_decode": "yuyv")"));
  ASSERT_TRUE(r) << r.error();
  EXPECT_EQ(r->jpeg_decode, "yuyv");
  auto old = read_recording(write_recording("rec_jpeg_old", ""));
  ASSERT_TRUE(old) << old.error();
  EXPECT_EQ(old->jpeg_decode, "bgr");
  for (const char* bad : {R"(, "jpeg_decode": "rgb")", R"(, "jpeg_decode": 1)"}) {
    auto b = read_recording(write_recording("rec_jpeg_bad", bad));
    ASSERT_FALSE(b) << bad;
    EXPECT_NE(b.error().find("jpeg_decode"), std::string::npos) << b.error();
  }
}

}  // namespace
}  // namespace dentar::session
