#include "dentar/calibration/camera_file.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "testutil.h"

namespace dentar::calibration {
namespace {

namespace fs = std::filesystem;
using test::read_file;
using test::temp_dir;
using test::write_file;

CameraFile sample() {
  CameraFile f;
  f.camera.width = 640;
  f.camera.height = 480;
  f.camera.fx = 600.123456789012;
  f.camera.fy = 601.5;
  f.camera.cx = 321.25;
  f.camera.cy = 239.75;
  f.camera.dist = {-0.12, 0.034, 0.001, -0.0005, 0.01};
  f.dist = {f.camera.dist.begin(), f.camera.dist.end()};
  f.rms_px = 0.183;
  f.std_devs = {0.4, 0.41, 0.3, 0.28, 0.002, 0.01, 1e-4, 1e-4, 0.02};
  f.date = "2026-11-22T01:30:00Z";
  f.device = "head camera SN 42";
  f.views_used = 12;
  return f;
}

void expect_same(const CameraFile& a, const CameraFile& b) {
  EXPECT_EQ(a.camera.width, b.camera.width);
  EXPECT_EQ(a.camera.height, b.camera.height);
  EXPECT_DOUBLE_EQ(a.camera.fx, b.camera.fx);
  EXPECT_DOUBLE_EQ(a.camera.fy, b.camera.fy);
  EXPECT_DOUBLE_EQ(a.camera.cx, b.camera.cx);
  EXPECT_DOUBLE_EQ(a.camera.cy, b.camera.cy);
  for (int i = 0; i < 5; ++i) EXPECT_DOUBLE_EQ(a.camera.dist[i], b.camera.dist[i]) << i;
  EXPECT_EQ(a.model, b.model);
}

TEST(CameraFile, YamlRoundTripKeepsEveryField) {
  const fs::path d = temp_dir("camfile_yaml");
  const CameraFile f = sample();
  ASSERT_TRUE(write_camera_file((d / "cam.yaml").string(), f).ok());
  auto r = read_camera_file((d / "cam.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(f, *r);
  EXPECT_EQ(r->source_format, "opencv-yaml");
  EXPECT_DOUBLE_EQ(r->rms_px, f.rms_px);
  ASSERT_EQ(r->std_devs.size(), f.std_devs.size());
  for (std::size_t i = 0; i < f.std_devs.size(); ++i) EXPECT_DOUBLE_EQ(r->std_devs[i], f.std_devs[i]);
  EXPECT_EQ(r->date, f.date);
  EXPECT_EQ(r->device, f.device);
  EXPECT_EQ(r->views_used, 12);
  EXPECT_TRUE(r->warning.empty());
  EXPECT_FALSE(fs::exists(d / "cam.yaml.tmp"));
}

TEST(CameraFile, XmlRoundTrip) {
  const fs::path d = temp_dir("camfile_xml");
  const CameraFile f = sample();
  ASSERT_TRUE(write_camera_file((d / "cam.xml").string(), f).ok());
  EXPECT_NE(read_file(d / "cam.xml").find("<?xml"), std::string::npos);
  auto r = read_camera_file((d / "cam.xml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(f, *r);
  EXPECT_EQ(r->source_format, "opencv-xml");
}

TEST(CameraFile, RosExportImportRoundTrip) {
  const fs::path d = temp_dir("camfile_ros");
  CameraFile f = sample();
  f.camera_name = "head_cam";
  ASSERT_TRUE(write_ros_camera_info((d / "ros.yaml").string(), f).ok());
  const std::string text = read_file(d / "ros.yaml");
  EXPECT_NE(text.find("distortion_model: plumb_bob"), std::string::npos);
  EXPECT_NE(text.find("projection_matrix:"), std::string::npos);
  auto r = read_camera_file((d / "ros.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(f, *r);
  EXPECT_EQ(r->source_format, "ros-yaml");
  EXPECT_EQ(r->camera_name, "head_cam");
}

TEST(CameraFile, ReadsRosRationalPolynomialWithWarning) {
  const fs::path d = temp_dir("camfile_ros_rat");
  write_file(d / "c.yaml",
             "image_width: 1280\nimage_height: 720\ncamera_name: cam0\n"
             "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [900, 0, 640, 0, 901, 360, 0, 0, 1]\n"
             "distortion_model: rational_polynomial\n"
             "distortion_coefficients:\n  rows: 1\n  cols: 8\n"
             "  data: [0.1, -0.2, 0.001, 0.002, 0.03, 0.05, -0.01, 0.004]\n"
             "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
             "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [900, 0, 640, 0, 0, 901, 360, 0, 0, 0, 1, 0]\n");
  auto r = read_camera_file((d / "c.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->model, kModelRational8);
  ASSERT_EQ(r->dist.size(), 8u);
  EXPECT_DOUBLE_EQ(r->dist[7], 0.004);
  EXPECT_DOUBLE_EQ(r->camera.dist[4], 0.03);
  EXPECT_DOUBLE_EQ(r->camera.fy, 901);
  EXPECT_NE(r->warning.find("k4..k6"), std::string::npos);
  // And back out as ROS rational_polynomial.
  ASSERT_TRUE(write_ros_camera_info((d / "o.yaml").string(), *r).ok());
  EXPECT_NE(read_file(d / "o.yaml").find("rational_polynomial"), std::string::npos);
}

// What OpenCV's samples/cpp/calibration.cpp writes (shipped as left_intrinsics.yml by opencv-doc).
TEST(CameraFile, ReadsOpenCvSampleOutput) {
  const fs::path d = temp_dir("camfile_sample");
  write_file(d / "s.yml",
             "%YAML:1.0\n---\ncalibration_time: \"Sun 22 Nov 2026\"\nnframes: 13\n"
             "image_width: 640\nimage_height: 480\nboard_width: 9\nboard_height: 6\n"
             "square_size: 2.5e-02\nflags: 2\n"
             "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
             "   data: [ 5.3591573396163199e+02, 0., 3.4228315473308373e+02, 0.,\n"
             "       5.3591573396163199e+02, 2.3557082909788173e+02, 0., 0., 1. ]\n"
             "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
             "   data: [ -2.66e-01, -3.85e-02, 1.78e-03, -2.81e-04, 2.38e-01 ]\n"
             "avg_reprojection_error: 3.9259098975581364e-01\n");
  auto r = read_camera_file((d / "s.yml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NEAR(r->camera.fx, 535.9157, 1e-3);
  EXPECT_NEAR(r->camera.cy, 235.5708, 1e-3);
  EXPECT_DOUBLE_EQ(r->camera.dist[4], 0.238);
  EXPECT_NEAR(r->rms_px, 0.3926, 1e-4);
  EXPECT_EQ(r->views_used, 13);
  EXPECT_EQ(r->date, "Sun 22 Nov 2026");
}

TEST(CameraFile, ReadsShippedOpenCvSampleFileWhenInstalled) {
  const fs::path p = "/usr/share/doc/opencv-doc/examples/data/left_intrinsics.yml";
  if (!fs::exists(p)) GTEST_SKIP() << p << " absent (install the Debian package opencv-doc)";
  auto r = read_camera_file(p.string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->camera.width, 640);
  EXPECT_GT(r->camera.fx, 400);
}

TEST(CameraFile, ReadsTutorialCapitalisedKeys) {
  const fs::path d = temp_dir("camfile_tut");
  write_file(d / "t.xml",
             "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_Width>640</image_Width>\n"
             "<image_Height>480</image_Height>\n<Camera_Matrix type_id=\"opencv-matrix\">"
             "<rows>3</rows><cols>3</cols><dt>d</dt><data>600. 0. 320. 0. 600. 240. 0. 0. 1."
             "</data></Camera_Matrix>\n<Distortion_Coefficients type_id=\"opencv-matrix\">"
             "<rows>5</rows><cols>1</cols><dt>d</dt><data>0.1 0.01 0. 0. 0.</data>"
             "</Distortion_Coefficients>\n<Avg_Reprojection_Error>0.2</Avg_Reprojection_Error>\n"
             "</opencv_storage>\n");
  auto r = read_camera_file((d / "t.xml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_DOUBLE_EQ(r->camera.fx, 600);
  EXPECT_DOUBLE_EQ(r->camera.dist[0], 0.1);
  EXPECT_DOUBLE_EQ(r->rms_px, 0.2);
}

// Bad files: each error names the file and the field.
struct BadCase {
  const char* name;
  const char* text;
  const char* expect;  // substring of the error
};

class CameraFileBad : public ::testing::TestWithParam<BadCase> {};

TEST_P(CameraFileBad, GivesAClearError) {
  const BadCase& c = GetParam();
  const fs::path d = temp_dir(std::string("camfile_bad_") + c.name);
  const fs::path p = d / "bad.yaml";
  write_file(p, c.text);
  auto r = read_camera_file(p.string());
  ASSERT_FALSE(r.ok()) << c.name;
  EXPECT_NE(r.error().find(p.string()), std::string::npos) << r.error();
  EXPECT_NE(r.error().find(c.expect), std::string::npos) << r.error();
}

INSTANTIATE_TEST_SUITE_P(
    Cases, CameraFileBad,
    ::testing::Values(
        BadCase{"empty", "", "empty"},
        BadCase{"not_yaml", "this is : not: [ a camera file\n\x01\x02", "camera file"},
        BadCase{"station_json",
                "{\n  \"name\": \"default\",\n  \"mannequin\": {},\n  \"calibration\": {}\n}\n",
                "station scene JSON"},
        BadCase{"missing_matrix",
                "%YAML:1.0\nimage_width: 640\nimage_height: 480\n"
                "distortion_coefficients: [0, 0, 0, 0, 0]\n",
                "camera_matrix"},
        BadCase{"missing_width", "%YAML:1.0\nimage_height: 480\n", "image_width"},
        BadCase{"wrong_matrix_size",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "camera_matrix:\n  rows: 2\n  cols: 2\n  data: [1, 0, 0, 1]\n",
                "must be 3x3"},
        BadCase{"rows_mismatch",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 1]\n",
                "does not match"},
        BadCase{"missing_dist",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n",
                "distortion_coefficients"},
        BadCase{"dist_count",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients:\n  rows: 1\n  cols: 3\n  data: [0, 0, 0]\n",
                "3 entries"},
        BadCase{"model_mismatch",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "distortion_model: rational_polynomial\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0, 0, 0, 0, 0]\n",
                "needs 8"},
        // Issue 24: the model name must agree with the coefficients.
        BadCase{"k1_model_with_k2",
                "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nmodel: pinhole-k1\n"
                "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                "  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n"
                "  data: [-0.2, 0.1, 0, 0, 0]\n",
                "model: model pinhole-k1 has k2 = 0.1"},
        BadCase{"k1k2_model_with_p1",
                "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nmodel: pinhole-k1k2\n"
                "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                "  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n"
                "  data: [-0.2, 0.1, 0.001, 0, 0]\n",
                "has p1 = 0.001"},
        BadCase{"unknown_model",
                "image_width: 640\nimage_height: 480\ndistortion_model: equidistant\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients:\n  rows: 1\n  cols: 4\n  data: [0, 0, 0, 0]\n",
                "equidistant"},
        BadCase{"negative_focal",
                "image_width: 640\nimage_height: 480\ncamera_name: c\n"
                "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [-600, 0, 320, 0, 600, 240, 0, 0, 1]\n"
                "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [0, 0, 0, 0, 0]\n",
                "fx"}),
    [](const ::testing::TestParamInfo<BadCase>& i) { return std::string(i.param.name); });

TEST(CameraFile, MissingFileNamesThePath) {
  auto r = read_camera_file("/nonexistent/dir/cam.yaml");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("/nonexistent/dir/cam.yaml"), std::string::npos);
}

TEST(CameraFile, HugeFileIsRefusedBeforeParsing) {
  const fs::path d = temp_dir("camfile_huge");
  write_file(d / "big.yaml", "%YAML:1.0\n---\n" + std::string(2u << 20, '#') + "\n");
  auto r = read_camera_file((d / "big.yaml").string());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("too large for a camera file"), std::string::npos) << r.error();
}

// Free text that OpenCV's writer or YAML reader would take for structure (fuzzing findings):
// every writer must produce a file that reads back.
TEST(CameraFile, TextStartingWithBracesRoundTrips) {
  const fs::path d = temp_dir("camfile_braces");
  CameraFile f = sample();
  f.date = "{un Nov 22 01:30:00 2026";
  f.device = "[left] cam: #2";
  f.camera_name = "{a: [1, {";
  for (const char* name : {"c.yaml", "c.xml"}) {
    ASSERT_TRUE(write_camera_file((d / name).string(), f).ok()) << name;
    auto r = read_camera_file((d / name).string());
    ASSERT_TRUE(r.ok()) << name << ": " << r.error();
    EXPECT_EQ(r->date, f.date) << name;
    EXPECT_EQ(r->device, f.device) << name;
    expect_same(f, *r);
  }
  ASSERT_TRUE(write_ros_camera_info((d / "ros.yaml").string(), f).ok());
  auto r = read_camera_file((d / "ros.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->camera_name, f.camera_name);
}

TEST(CameraFile, WriteRefusesInvalidContentAndLeavesNoFile) {
  const fs::path d = temp_dir("camfile_badwrite");
  CameraFile f = sample();
  f.camera.fx = -1;
  EXPECT_FALSE(write_camera_file((d / "c.yaml").string(), f).ok());
  EXPECT_FALSE(write_ros_camera_info((d / "r.yaml").string(), f).ok());
  EXPECT_FALSE(fs::exists(d / "c.yaml"));
  EXPECT_FALSE(fs::exists(d / "r.yaml"));
  EXPECT_FALSE(write_camera_file((d / "c.json").string(), sample()).ok());
}

// Inputs the fuzzer (calibration/fuzz) found to crash the reader inside
// OpenCV 4.6: each must now be a clear error naming the file.
TEST(CameraFile, FuzzFindingsAreErrorsNotCrashes) {
  const fs::path d = temp_dir("camfile_fuzz_findings");
  const std::pair<const char*, std::string> cases[] = {
      {"length_error.yaml", std::string(" t:d\n :", 7)},  // std::length_error from the YAML parser
      {"xml_eof.xml", "<?xml v="},                          // SIGSEGV: attribute cut after '='
      {"xml_cr.xml", std::string("<?xml version=\r\r\r\r\"1.\r0\"?>\r\r\x1d", 29)},
  };
  for (const auto& [name, bytes] : cases) {
    write_file(d / name, bytes);
    const auto r = read_camera_file((d / name).string());
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_NE(r.error().find(name), std::string::npos) << r.error();
  }
}

TEST(CameraFile, RosExportKeepsLargeIntegralValues) {
  // A value above INT_MAX printed without a decimal point read back as a
  // wrapped int (fuzz finding); the writer now always marks reals.
  const fs::path d = temp_dir("camfile_ros_big");
  CameraFile f;
  f.camera.width = 640;
  f.camera.height = 480;
  f.camera.fx = 4096.0;  // integral values, as a user may type them
  f.camera.fy = 4096.0;
  f.camera.cx = 320.0;
  f.camera.cy = 240.0;
  f.camera.dist = {3e9, 0, 0, 0, 0};  // integral and above INT_MAX
  f.dist.assign(f.camera.dist.begin(), f.camera.dist.end());
  ASSERT_TRUE(write_ros_camera_info((d / "ros.yaml").string(), f).ok());
  const auto back = read_camera_file((d / "ros.yaml").string());
  ASSERT_TRUE(back.ok()) << back.error();
  EXPECT_EQ(back->camera.fx, 4096.0);
  EXPECT_EQ(back->camera.dist[0], 3e9);
}

}  // namespace
}  // namespace dentar::calibration


namespace dentar::calibration {
// Issue 24: a k1-only calibration is written and read back as pinhole-k1, not
// pinhole-radtan5; the k1k2 name likewise.
TEST(CameraFile, NamesTheModelAsFitted) {
  const fs::path d = temp_dir("camfile_k1");
  CameraFile f;
  f.camera.width = 640;
  f.camera.height = 480;
  f.camera.fx = f.camera.fy = 600;
  f.camera.cx = 320;
  f.camera.cy = 240;
  f.camera.dist = {-0.21, 0, 0, 0, 0};
  f.model = kModelK1;
  f.dist = {-0.21, 0, 0, 0, 0};
  ASSERT_TRUE(write_camera_file((d / "k1.yaml").string(), f).ok());
  auto r = read_camera_file((d / "k1.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->model, kModelK1);
  f.model = kModelK1K2;
  f.camera.dist[1] = f.dist[1] = 0.05;
  ASSERT_TRUE(write_camera_file((d / "k1k2.yaml").string(), f).ok());
  r = read_camera_file((d / "k1k2.yaml").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->model, kModelK1K2);
  // The struct itself refuses a mismatch, naming the model and the coefficient.
  f.model = kModelK1;
  const std::string e = f.validate();
  EXPECT_NE(e.find("pinhole-k1 has k2"), std::string::npos) << e;
  EXPECT_FALSE(write_camera_file((d / "bad.yaml").string(), f).ok());
}
}  // namespace dentar::calibration
