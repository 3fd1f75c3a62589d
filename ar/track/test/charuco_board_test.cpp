// ChArUco boards (issue 28): the board spec, our printed layout against OpenCV 4.6's own drawing,
// detection on rendered views (whole and partial) against the projected truth, and a camera
// calibration from generated views with real-world faults (blur, noise, JPEG, strong perspective)
// against the known camera. The ChArUco-against-chessboard benchmark runs with
// DENTAR_CHARUCO_VIEWS set (docs/BENCHMARKS.md, issue 28 session 15).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dentar/ar/calib_board.h"
#include "dentar/calibration/intrinsics.h"

namespace dentar::ar {
namespace {

calibration::CameraIntrinsics cam() {
  calibration::CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = k.fy = 600;
  k.cx = 322;
  k.cy = 236;
  k.dist = {-0.12, 0.05, 0, 0, 0};
  return k;
}

CharucoSpec board() {
  auto s = parse_board_spec("charuco:9x7:20:15:DICT_4X4_50");
  EXPECT_TRUE(s.ok()) << s.error();
  return std::get<CharucoSpec>(*s);
}

// Real-world faults on a rendered view: JPEG at the given quality (0 = none).
cv::Mat jpeg(const cv::Mat& img, int quality) {
  if (quality <= 0) return img;
  std::vector<std::uint8_t> buf;
  cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, quality});
  return cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
}

// Detected corners against the projected truth, paired by board point: RMS px, count.
std::pair<double, int> corner_rms(const calibration::BoardView& v, const std::vector<Eigen::Vector3d>& obj,
                                  const std::vector<Eigen::Vector2d>& truth) {
  double sq = 0;
  int n = 0;
  for (std::size_t i = 0; i < v.object_points.size(); ++i)
    for (std::size_t j = 0; j < obj.size(); ++j)
      if ((obj[j] - v.object_points[i]).norm() < 1e-9) {
        sq += (v.image_points[i] - truth[j]).squaredNorm();
        ++n;
      }
  return {n ? std::sqrt(sq / n) : 1e9, n};
}

TEST(CharucoBoard, SpecParsingNamesTheFieldAndTheForm) {
  auto s = parse_board_spec("charuco:5x7:40:30:4x4_50");
  ASSERT_TRUE(s.ok()) << s.error();
  const auto& h = std::get<CharucoSpec>(*s);
  EXPECT_EQ(h.cols, 5);
  EXPECT_EQ(h.rows, 7);
  EXPECT_DOUBLE_EQ(h.square_m, 0.04);
  EXPECT_DOUBLE_EQ(h.marker_m, 0.03);
  EXPECT_EQ(h.dictionary, "DICT_4X4_50");
  EXPECT_EQ(h.marker_count(), 17);
  EXPECT_EQ(h.corner_count(), 24);
  EXPECT_EQ(board_spec_to_string(*s), "charuco:5x7:40:30:DICT_4X4_50:0");
  EXPECT_TRUE(parse_board_spec(board_spec_to_string(*s)).ok());
  auto a = parse_board_spec("charuco:11x8:15:11:dict_apriltag_36h11:100");
  ASSERT_TRUE(a.ok()) << a.error();
  EXPECT_EQ(std::get<CharucoSpec>(*a).dictionary, "DICT_APRILTAG_36h11");
  EXPECT_EQ(std::get<CharucoSpec>(*a).first_id, 100);
  EXPECT_NEAR(board_width_m(*a), 9 * 0.015, 1e-12);  // inner corners' extent
  // Each malformed spec: the field named, the allowed form given.
  const std::pair<const char*, const char*> bad[] = {
      {"charuco:5x7:40:30", "takes 4 to 5 fields"},
      {"charuco:5by7:40:30:DICT_4X4_50", "COLSxROWS \"5by7\""},
      {"charuco:5x7:forty:30:DICT_4X4_50", "SQUARE_MM \"forty\""},
      {"charuco:5x7:40:-3:DICT_4X4_50", "MARKER_MM \"-3\""},
      {"charuco:5x7:40:30:DICT_9X9_50", "DICT \"DICT_9X9_50\""},
      {"charuco:5x7:40:30:DICT_4X4_50:1.5", "FIRST_ID \"1.5\""},
      {"charuco:5x7:40:45:DICT_4X4_50", "marker size"},
      {"charuco:2x7:40:30:DICT_4X4_50", "3..100"},
      {"charuco:12x12:40:30:DICT_4X4_50", "has 50 codes"},
      {"chessboard:9x6:2o", "SQUARE_MM \"2o\""},
      {"aprilgrid:6x5:24:8:tag99", "FAMILY \"tag99\""},
      {"kalibr:6x6:88", "takes 3 to 4 fields"},
  };
  for (const auto& [text, want] : bad) {
    auto r = parse_board_spec(text);
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().rfind(std::string("board \"") + text + "\"", 0), 0u) << r.error();
    EXPECT_NE(r.error().find(want), std::string::npos) << text << ": " << r.error();
    if (std::string(text).rfind("charuco", 0) == 0) {
      EXPECT_NE(r.error().find("charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICT"), std::string::npos) << r.error();
    }
  }
}

// Our printed board (make_board_texture, used by the renderer) is OpenCV 4.6's ChArUco board:
// the same squares and markers where CharucoBoard::draw puts them, and its corner ids at our
// object points (shifted by one square: our origin is the first inner corner).
TEST(CharucoBoard, LayoutIsOpenCvsOwn) {
  for (const char* text : {"charuco:9x7:20:15:DICT_4X4_50", "charuco:6x8:20:15:DICT_4X4_50"}) {  // odd and even rows
  SCOPED_TRACE(text);
  const CharucoSpec h = std::get<CharucoSpec>(*parse_board_spec(text));
  const double px_per_sq = 60;
  auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  auto cb = cv::aruco::CharucoBoard::create(h.cols, h.rows, static_cast<float>(h.square_m),
                                            static_cast<float>(h.marker_m), dict);
  cv::Mat theirs;
  cb->draw(cv::Size(static_cast<int>(h.cols * px_per_sq), static_cast<int>(h.rows * px_per_sq)), theirs, 0, 1);
  const BoardTexture tex = make_board_texture(BoardSpec(h), px_per_sq / h.square_m);
  // Texture pixel of board point (-square, -square) (the board's outer top-left corner).
  const int x0 = static_cast<int>(std::lround((-h.square_m - tex.origin_m.x()) * tex.px_per_m));
  const int y0 = static_cast<int>(std::lround((-h.square_m - tex.origin_m.y()) * tex.px_per_m));
  ASSERT_GE(x0, 0);
  const cv::Mat ours = tex.image(cv::Rect(x0, y0, theirs.cols, theirs.rows));
  cv::Mat diff;
  cv::absdiff(ours, theirs, diff);
  // OpenCV rounds each marker's place to whole pixels: 1-pixel seams along marker edges are
  // not a difference of layout (a wrong marker, square or id order differs in whole cells).
  cv::Mat differs = diff > 128;
  cv::morphologyEx(differs, differs, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  const double differ = cv::countNonZero(differs) / static_cast<double>(diff.total());
  EXPECT_LT(differ, 0.002) << "printed layout differs from OpenCV's in " << differ * 100 << " % of the pixels";
  EXPECT_GT(cv::countNonZero(theirs < 128), static_cast<int>(theirs.total() / 3));  // not a blank comparison
  const auto obj = h.object_points();
  ASSERT_EQ(cb->chessboardCorners.size(), obj.size());
  for (std::size_t i = 0; i < obj.size(); ++i) {
    EXPECT_NEAR(cb->chessboardCorners[i].x - h.square_m, obj[i].x(), 1e-6) << i;
    EXPECT_NEAR(cb->chessboardCorners[i].y - h.square_m, obj[i].y(), 1e-6) << i;
  }
  }
}

TEST(CharucoBoard, DetectsWholeAndPartialViewsAtTheTrueCorners) {
  const auto k = cam();
  const CharucoSpec h = board();
  const BoardSpec spec = h;
  const BoardTexture tex = make_board_texture(spec, 5000);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.6, 0.8, 0).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0, 0, 0.32) - T.linear() * Eigen::Vector3d(board_width_m(spec) / 2, board_height_m(spec) / 2, 0);
  BoardRenderOptions ro;
  ro.supersample = 2;
  auto det = BoardDetector::create(spec);
  ASSERT_TRUE(det.ok()) << det.error();
  const cv::Mat whole = render_board_view(tex, k, T, ro);
  auto v = det->detect(whole, "whole");
  ASSERT_TRUE(v.ok()) << v.error();
  const auto [rms, n] = corner_rms(*v, h.object_points(), project_board_points(spec, k, T));
  std::printf("[ charuco ] whole view: %d of %d corners, RMS %.3f px\n", n, h.corner_count(), rms);
  EXPECT_EQ(n, static_cast<int>(v->image_points.size()));  // every corner at a board point
  EXPECT_GE(n, h.corner_count() - 2);
  EXPECT_LT(rms, 0.15);
  // Half the board out of the image (slid right): the corners still seen, with their ids.
  Eigen::Isometry3d P = T;
  P.translation().x() += 0.15;
  const cv::Mat part = render_board_view(tex, k, P, ro);
  auto p = det->detect(part, "partial");
  ASSERT_TRUE(p.ok()) << p.error();
  const auto truth = project_board_points(spec, k, P);
  const auto [prms, pn] = corner_rms(*p, h.object_points(), truth);
  int inside = 0;
  for (const auto& q : truth) inside += q.x() > 8 && q.y() > 8 && q.x() < k.width - 9 && q.y() < k.height - 9;
  std::printf("[ charuco ] partial view: %d corners (%d inside the image), RMS %.3f px\n", pn, inside, prms);
  EXPECT_EQ(pn, static_cast<int>(p->image_points.size()));
  EXPECT_LT(inside, h.corner_count() * 3 / 4);
  EXPECT_GE(pn, inside * 3 / 4);
  EXPECT_LT(prms, 0.2);
  // A blank image and a wrong dictionary: not found, said so with the name.
  auto none = det->detect(cv::Mat(120, 160, CV_8UC1, cv::Scalar(128)), "blank.png");
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("board not found in blank.png"), std::string::npos) << none.error();
  CharucoSpec other = h;
  other.dictionary = "DICT_6X6_250";
  auto wrong = detect_board(whole, other, "whole.png");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().find("DICT_6X6_250"), std::string::npos) << wrong.error();
}

// The legacy layout (even rows: the top-left square white) rendered and found at its true
// corners through the board geometry rewritten for it; OpenCV 4.6's layout does not read it.
TEST(CharucoBoard, LegacyLayoutIsFoundAtTheTrueCorners) {
  const auto k = cam();
  auto ls = parse_board_spec("charuco:6x8:20:15:DICT_4X4_50:legacy");
  ASSERT_TRUE(ls.ok()) << ls.error();
  const CharucoSpec h = std::get<CharucoSpec>(*ls);
  ASSERT_TRUE(h.legacy);
  EXPECT_TRUE(h.white(0, 0));  // 8 rows: white top-left
  EXPECT_EQ(board_spec_to_string(*ls), "charuco:6x8:20:15:DICT_4X4_50:0:legacy");
  const BoardTexture tex = make_board_texture(*ls, 5000);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.8, 0.6, 0).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0, 0, 0.3) - T.linear() * Eigen::Vector3d(board_width_m(*ls) / 2, board_height_m(*ls) / 2, 0);
  BoardRenderOptions ro;
  ro.supersample = 2;
  const cv::Mat img = render_board_view(tex, k, T, ro);
  CharucoStats st;
  auto v = detect_charuco(img, h, "legacy", 6, &st);
  ASSERT_TRUE(v.ok()) << v.error();
  const auto [rms, n] = corner_rms(*v, h.object_points(), project_board_points(*ls, k, T));
  std::printf("[ charuco ] legacy board: %d markers, %d of %d corners, RMS %.3f px\n", st.markers, n, h.corner_count(), rms);
  EXPECT_EQ(st.markers, h.marker_count());
  EXPECT_GE(n, h.corner_count() - 2);
  EXPECT_LT(rms, 0.15);
  // (Read with OpenCV 4.6's layout, a whole legacy board is still found here: each inner corner's
  // two markers sit one square off in opposite directions and OpenCV averages their predictions.
  // A corner predicted from one marker alone lands one square off: the real photo below.)
}

// Corners against one plane: RMS distance from the best homography of the board's layout, px.
double layout_rms_px(const calibration::BoardView& v) {
  std::vector<cv::Point2f> o, p;
  for (std::size_t i = 0; i < v.image_points.size(); ++i) {
    o.emplace_back(static_cast<float>(v.object_points[i].x()), static_cast<float>(v.object_points[i].y()));
    p.emplace_back(static_cast<float>(v.image_points[i].x()), static_cast<float>(v.image_points[i].y()));
  }
  const cv::Mat H = cv::findHomography(o, p, 0);
  if (H.empty()) return 1e9;
  std::vector<cv::Point2f> q;
  cv::perspectiveTransform(o, q, H);
  double sq = 0;
  for (std::size_t i = 0; i < q.size(); ++i) sq += cv::norm(q[i] - p[i]) * cv::norm(q[i] - p[i]);
  return std::sqrt(sq / static_cast<double>(q.size()));
}

// A real photograph: OpenCV's ChArUco calibration tutorial screenshot (Debian opencv-doc,
// html/screen_charuco.jpg; a webcam photo of a printed 6x8-square DICT_4X4_50 board held by hand,
// turned 90 degrees, with the tutorial's own detections drawn over it). Read where Debian
// installs it, never copied into the repository; skipped when opencv-doc is absent. The board was
// printed before OpenCV 4.6: with 8 rows its top-left square is white (the legacy layout): its
// markers fit the legacy squares, not OpenCV 4.6's. Read as the legacy board, our detector finds
// its corners where one plane puts them (within the lens distortion the screenshot prints: k1
// 0.06, k2 -0.44). Read as 4.6's layout it finds fewer (printed, not asserted).
TEST(CharucoBoard, RealPhotographOfALegacyBoard) {
  const std::string path = "/usr/share/doc/opencv-doc/opencv4/html/screen_charuco.jpg";
  const cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) GTEST_SKIP() << path << " absent (Debian package opencv-doc)";
  const cv::Mat photo = img(cv::Rect(30, 40, 530, 290)).clone();  // the camera panel of the screenshot
  auto legacy = parse_board_spec("charuco:6x8:40:25:DICT_4X4_50:legacy");
  ASSERT_TRUE(legacy.ok()) << legacy.error();
  EXPECT_TRUE(std::get<CharucoSpec>(*legacy).legacy);
  CharucoStats st;
  auto v = detect_charuco(photo, std::get<CharucoSpec>(*legacy), "screen_charuco.jpg", 6, &st);
  ASSERT_TRUE(v.ok()) << v.error();
  const double rms = layout_rms_px(*v);
  std::printf("[ charuco real ] %s as the legacy board: %d markers, %d of 35 corners, layout RMS %.2f px\n",
              path.c_str(), st.markers, st.corners, rms);
  EXPECT_GE(st.corners, 20);
  EXPECT_LT(rms, 1.5);
  // Which layout the print has: the markers found (OpenCV's detector alone) against the centres of
  // the squares each layout gives their ids, through one homography. Only the legacy layout fits.
  std::vector<std::vector<cv::Point2f>> mc;
  std::vector<int> ids;
  cv::aruco::detectMarkers(photo, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50), mc, ids);
  ASSERT_GE(ids.size(), 10u);
  auto marker_fit_px = [&](const CharucoSpec& h) {
    std::vector<Eigen::Vector2d> centre;  // by marker index, board frame (squares)
    for (int j = 0; j < h.rows; ++j)
      for (int i = 0; i < h.cols; ++i)
        if (h.white(i, j)) centre.emplace_back(i - 0.5, j - 0.5);
    calibration::BoardView v;
    for (std::size_t m = 0; m < ids.size(); ++m) {
      if (ids[m] < 0 || ids[m] >= static_cast<int>(centre.size())) continue;
      const cv::Point2f c = (mc[m][0] + mc[m][1] + mc[m][2] + mc[m][3]) * 0.25f;
      v.image_points.emplace_back(c.x, c.y);
      const auto& q = centre[static_cast<std::size_t>(ids[m])];
      v.object_points.emplace_back(q.x(), q.y(), 0.0);
    }
    return layout_rms_px(v);
  };
  CharucoSpec h46 = std::get<CharucoSpec>(*legacy);
  h46.legacy = false;
  const double fit_legacy = marker_fit_px(std::get<CharucoSpec>(*legacy)), fit46 = marker_fit_px(h46);
  std::printf("[ charuco real ] %zu markers against the squares' centres: legacy layout RMS %.2f px, OpenCV 4.6's %.2f px\n",
              ids.size(), fit_legacy, fit46);
  // The same photo read with 4.6's layout: corners at a place the legacy reading also found, but
  // under another board point (one square off), or at the same board point.
  auto w = detect_charuco(photo, h46, "screen_charuco.jpg", 0);
  int same = 0, moved = 0;
  if (w)
    for (std::size_t i = 0; i < w->image_points.size(); ++i)
      for (std::size_t j = 0; j < v->image_points.size(); ++j)
        if ((w->image_points[i] - v->image_points[j]).norm() < 1.0)
          ((w->object_points[i] - v->object_points[j]).norm() < 1e-9 ? same : moved)++;
  std::printf("[ charuco real ] read as 4.6's layout: %zu corners; of those also found by the legacy reading, %d under "
              "the same board point, %d under another\n", w ? w->image_points.size() : 0, same, moved);
  EXPECT_LT(fit_legacy, 2.0);
  EXPECT_GT(fit46, 4 * fit_legacy);
}

struct SessionResult {
  int views = 0, found = 0;
  double fx_err_rel = 0, k1_err = 0, cx_err = 0, rms_px = 0;
  bool ok = false;
};

// A generated photo session of the board with faults, calibrated; the chosen faults are those of
// a phone or webcam photo: 1 px blur, 3 DN noise, JPEG quality 75, tilts up to ~45 degrees.
SessionResult calibrate_session(const BoardSpec& spec, int views, std::uint64_t seed) {
  const auto k = cam();
  BoardRenderOptions ro;
  ro.supersample = 2;
  ro.blur_sigma_px = 1.0;
  ro.noise_sigma_dn = 3;
  const SimulatedBoardSession s = simulate_board_session(spec, k, views, seed, -1, 0, ro);
  auto det = BoardDetector::create(spec);
  EXPECT_TRUE(det.ok());
  std::vector<calibration::BoardView> v;
  SessionResult r;
  r.views = views;
  for (int i = 0; i < views; ++i) {
    auto d = det->detect(jpeg(s.images[static_cast<std::size_t>(i)], 75), "sim-" + std::to_string(i));
    if (d) v.push_back(*d);
  }
  r.found = static_cast<int>(v.size());
  const auto c = calibration::calibrate_intrinsics(v, k.width, k.height);
  r.ok = c.ok;
  r.fx_err_rel = std::abs(c.camera.fx - k.fx) / k.fx;
  r.cx_err = std::abs(c.camera.cx - k.cx);
  r.k1_err = std::abs(c.camera.dist[0] - k.dist[0]);
  r.rms_px = c.rms_px;
  return r;
}

TEST(CharucoBoard, CalibratesAKnownCameraFromFaultyViews) {
  const SessionResult r = calibrate_session(board(), 10, 5);
  std::printf("[ charuco ] calibration: %d of %d views found, rms %.3f px, |dfx|/fx %.4f %%, |dcx| %.2f px, "
              "|dk1| %.4f\n",
              r.found, r.views, r.rms_px, r.fx_err_rel * 100, r.cx_err, r.k1_err);
  ASSERT_TRUE(r.ok);
  EXPECT_GE(r.found, 9);
  // Stated error: focal length within 0.5 %, principal point within 3 px, k1 within 0.02.
  EXPECT_LT(r.fx_err_rel, 0.005);
  EXPECT_LT(r.cx_err, 3.0);
  EXPECT_LT(r.k1_err, 0.02);
  EXPECT_LT(r.rms_px, 0.5);
}

// Benchmark (DENTAR_CHARUCO_VIEWS=N): ChArUco against the chessboard of the same squares on the
// same generated views (same poses, same faults), half of them with the board partly out of
// the image: detection rate, corner RMS against the truth, time per image; then each board's
// calibration error.
TEST(CharucoBoard, BenchmarkAgainstChessboard) {
  const char* nv = std::getenv("DENTAR_CHARUCO_VIEWS");
  if (!nv) GTEST_SKIP() << "set DENTAR_CHARUCO_VIEWS";
  const int n = std::atoi(nv);
  const auto k = cam();
  const CharucoSpec h = board();
  const calibration::ChessboardSpec cs{h.cols - 1, h.rows - 1, h.square_m};
  const auto poses = calibration::plan_board_poses(k, board_width_m(h), board_height_m(h), n, 31);
  for (const BoardSpec& spec : {BoardSpec(h), BoardSpec(cs)}) {
    const BoardTexture tex = make_board_texture(spec, 5000);
    auto det = BoardDetector::create(spec);
    ASSERT_TRUE(det.ok());
    const std::vector<Eigen::Vector3d> obj =
        std::holds_alternative<CharucoSpec>(spec) ? h.object_points() : cs.object_points();
    int found[2] = {0, 0}, corners[2] = {0, 0}, visible[2] = {0, 0};
    double sq[2] = {0, 0}, time_s[2] = {0, 0}, cpu_s[2] = {0, 0};
    std::vector<calibration::BoardView> views;
    for (int i = 0; i < n; ++i)
      for (int partial = 0; partial < 2; ++partial) {
        Eigen::Isometry3d T = poses[static_cast<std::size_t>(i)];
        if (partial) {  // slide the board so that about a third of it leaves the image
          const Eigen::Vector3d c = T * Eigen::Vector3d(board_width_m(h) / 2, board_height_m(h) / 2, 0);
          T.translation().x() += (c.x() >= 0 ? 1 : -1) * 0.4 * board_width_m(h) * c.z() / 0.3;
        }
        BoardRenderOptions ro;
        ro.supersample = 2;
        ro.blur_sigma_px = 1.0;
        ro.noise_sigma_dn = 3;
        ro.seed = 1000 + static_cast<std::uint64_t>(i);
        const cv::Mat img = jpeg(render_board_view(tex, k, T, ro), 75);
        const auto truth = project_board_points(spec, k, T);
        for (const auto& q : truth) visible[partial] += q.x() > 8 && q.y() > 8 && q.x() < k.width - 9 && q.y() < k.height - 9;
        const auto t0 = std::chrono::steady_clock::now();
        const std::clock_t c0 = std::clock();  // the process's CPU time, OpenCV's threads included
        auto d = det->detect(img, "bench");
        cpu_s[partial] += static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
        time_s[partial] += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (!d) continue;
        ++found[partial];
        auto [rms, m] = corner_rms(*d, obj, truth);
        if (std::holds_alternative<calibration::ChessboardSpec>(spec)) {
          // A chessboard's order is ambiguous up to a half turn: take the nearer reading.
          std::vector<Eigen::Vector2d> rev(truth.rbegin(), truth.rend());
          const auto r2 = corner_rms(*d, obj, rev);
          if (r2.first < rms) std::tie(rms, m) = r2;
        }
        corners[partial] += m;
        sq[partial] += rms * rms * m;
        if (!partial || std::holds_alternative<CharucoSpec>(spec)) views.push_back(*d);
      }
    const auto c = calibration::calibrate_intrinsics(views, k.width, k.height);
    for (int partial = 0; partial < 2; ++partial)
      std::printf("[ charuco bench ] %s %s views: found %d/%d, corners %d of %d inside the image (%.1f %%), "
                  "corner RMS %.3f px, %.1f ms per image (CPU %.1f ms)\n",
                  board_spec_to_string(spec).c_str(), partial ? "partial" : "whole", found[partial], n, corners[partial],
                  visible[partial], 100.0 * corners[partial] / std::max(1, visible[partial]),
                  std::sqrt(sq[partial] / std::max(1, corners[partial])), 1e3 * time_s[partial] / n,
                  1e3 * cpu_s[partial] / n);
    std::printf("[ charuco bench ] %s calibration from %zu views: ok %d rms %.3f px, fx err %.3f px (%.3f %%), "
                "cx err %.2f px, cy err %.2f px, k1 err %.4f, k2 err %.4f\n",
                board_spec_to_string(spec).c_str(), views.size(), c.ok, c.rms_px, c.camera.fx - k.fx,
                100 * (c.camera.fx - k.fx) / k.fx, c.camera.cx - k.cx, c.camera.cy - k.cy, c.camera.dist[0] - k.dist[0],
                c.camera.dist[1] - k.dist[1]);
  }
}

}  // namespace
}  // namespace dentar::ar
