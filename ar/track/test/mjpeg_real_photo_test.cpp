// Issue 28, session 19: the Motion JPEG decode default (MjpegDecoder -> YUYV, the
// tracker reading the luma: live --camera-format auto|mjpg) against the decode
// before it (cv::imdecode -> BGR -> the tracker's grey) on *real* photographs,
// through the detection, corner refit and pose code the live tracker uses
// (TagDetector with the tracker's options, estimate_bundle_pose on a one-tag
// bundle) and through the calibration's chessboard corner finder.
//
// Three grey images of the same JPEG bytes:
//   old     cv::imdecode(IMREAD_COLOR) -> FrameGray (COLOR_BGR2GRAY)
//   yuyv    MjpegDecoder(kYuyv) -> FrameGray (the limited-range luma stretched back)
//   Yplane  cv::imdecode(IMREAD_GRAYSCALE): the JPEG's own luma plane, full range
//           (libjpeg's YCbCr -> grey output takes Y as it is): what both should be.
//
// The JPEGs (each test skips when its files are absent):
//   - tests/data/apriltag_photos: three real JPEG photos (Flickr, 4:4:4, 799 px
//     wide), decoded from their bytes as they are; their width is odd, and the
//     YUYV default needs an even width (it falls back to BGR: checked), so they
//     are also cropped to 798 px *losslessly* (tjTransform: the same DCT
//     coefficients) to put the YUYV path itself on the photo's own bytes.
//     Reference: libapriltag's own corners (a detection, not truth).
//   - ViSP's AprilTag.pgm (a real 640x480 grey photo, ViSP's reference corners and
//     poses) and its rendered benchmark PNGs (truth from the render's poses),
//     encoded as a UVC camera's MJPG: TurboJPEG 2.1 tjCompress2 from BGR, the
//     accurate integer DCT (flags 0), 4:2:2 at quality 80 and 95 and 4:2:0 at 80.
//   - OpenCV's chessboard photos (opencv-doc: left/right01..14.jpg, grey JPEGs,
//     9x6 inner corners), bytes as they are and re-encoded at 4:2:2 quality 80.
// The bounds and the measured values are in docs/BENCHMARKS.md, "Issue 28 session 19
// — the MJPG decode on real photos".
#include <gtest/gtest.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/calib3d.hpp>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/calib_board.h"
#include "dentar/calibration/chessboard_grid.h"
#include "swarm_photos.h"
#include "dentar/ar/frame_gray.h"
#include "dentar/ar/mjpeg_decoder.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/ar/tracker.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;
using Corners = std::array<Eigen::Vector2d, 4>;

const fs::path kViSP = "/usr/share/visp-images-data/ViSP-images/AprilTag";
const fs::path kSwarm = fs::path(DENTAR_SOURCE_DIR) / "tests/data/apriltag_photos";
const fs::path kOpenCV = "/usr/share/doc/opencv-doc/examples/data";

// ---- JPEG bytes ----

Bytes read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A UVC camera's MJPG frame: TurboJPEG from BGR, accurate DCT, given chroma subsampling.
Bytes encode_uvc(const cv::Mat& bgr, int subsamp, int quality) {
  tjhandle tj = tjInitCompress();
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  const int r = tjCompress2(tj, bgr.data, bgr.cols, static_cast<int>(bgr.step[0]), bgr.rows, TJPF_BGR, &buf, &size,
                            subsamp, quality, 0);
  Bytes out;
  if (r == 0) out.assign(buf, buf + size);
  tjFree(buf);
  tjDestroy(tj);
  return out;
}

// The JPEG cropped to an even width without re-encoding (the same DCT coefficients;
// the left edge stays at 0, so no MCU alignment is needed).
Bytes crop_to_even_width(const Bytes& jpg, int w, int h) {
  tjhandle tj = tjInitTransform();
  tjtransform xf{};
  xf.r = tjregion{0, 0, w - (w % 2), h};
  xf.op = TJXOP_NONE;
  xf.options = TJXOPT_CROP;
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  const int r = tjTransform(tj, jpg.data(), jpg.size(), 1, &buf, &size, &xf, 0);
  Bytes out;
  if (r == 0) out.assign(buf, buf + size);
  tjFree(buf);
  tjDestroy(tj);
  return out;
}

// ---- The three greys of one JPEG ----

struct Greys {
  cv::Mat old_gray, yuyv_gray, y_plane;
  int yuyv_type = 0;  // what MjpegDecoder handed on (CV_8UC2 unless it fell back to BGR)
  // The shown colour: imdecode's BGR against the YUYV frame converted as the compositor and the
  // recorder convert it (COLOR_YUV2BGR_YUYV): max / mean absolute difference per channel.
  int colour_max = 0;
  double colour_mean = 0;
};

cv::Mat tracker_gray(const cv::Mat& frame) {
  FrameGray fg;
  fg.reset(frame);
  return fg.whole().clone();
}

Greys decode_three(const Bytes& jpg) {
  Greys g;
  const cv::Mat bgr = cv::imdecode(jpg, cv::IMREAD_COLOR);
  EXPECT_FALSE(bgr.empty());
  g.old_gray = tracker_gray(bgr);
  MjpegDecoder dec(false);
  cv::Mat yuyv;
  EXPECT_TRUE(dec.decode(jpg.data(), jpg.size(), MjpegOutput::kYuyv, yuyv)) << dec.why();
  g.yuyv_type = yuyv.type();
  g.yuyv_gray = tracker_gray(yuyv);
  if (yuyv.type() == CV_8UC2) {
    cv::Mat shown, d;
    cv::cvtColor(yuyv, shown, cv::COLOR_YUV2BGR_YUYV);
    cv::absdiff(shown, bgr, d);
    double mx = 0;
    cv::minMaxLoc(d.reshape(1), nullptr, &mx);
    g.colour_max = static_cast<int>(mx);
    const cv::Scalar m = cv::mean(d);
    g.colour_mean = (m[0] + m[1] + m[2]) / 3;
  }
  g.y_plane = cv::imdecode(jpg, cv::IMREAD_GRAYSCALE);
  return g;
}

// Grey-level difference a - b: max |d| and mean |d|.
std::pair<int, double> grey_diff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  double mx = 0;
  cv::minMaxLoc(d, nullptr, &mx);
  return {static_cast<int>(mx), cv::mean(d)[0]};
}

// ---- Tags: detection, matching, pose ----

struct Ref {
  int id = 0;  // -1: match by position only
  Corners corners;
  double size_m = 0;
  std::optional<Eigen::Isometry3d> T_cam_tag;  // our (libapriltag's) tag frame
};

struct Case {
  std::string name;
  TagFamilyId family = TagFamilyId::kTag36h11;
  std::optional<calibration::CameraIntrinsics> cam;
  std::vector<Ref> refs;
  std::string ref_kind;  // "truth", "ViSP", "libapriltag"
};

Eigen::Vector2d centre(const Corners& c) { return (c[0] + c[1] + c[2] + c[3]) / 4; }

// Index of the detection matching `c` (same id unless id < 0, centre within half a side), or -1.
int match(const std::vector<DetectedTag>& det, int id, const Corners& c, std::vector<bool>& used) {
  const double side = (c[1] - c[0]).norm();
  int best = -1;
  double best_d = 0.5 * side;
  for (std::size_t i = 0; i < det.size(); ++i) {
    if (used[i] || (id >= 0 && det[i].id != id)) continue;
    const double d = (centre(det[i].corners_px) - centre(c)).norm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(i);
    }
  }
  if (best >= 0) used[static_cast<std::size_t>(best)] = true;
  return best;
}

double max_corner_px(const Corners& a, const Corners& b) {
  double m = 0;
  for (int k = 0; k < 4; ++k) m = std::max(m, (a[k] - b[k]).norm());
  return m;
}

double rot_deg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const double c = std::clamp(((A.transpose() * B).trace() - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180 / M_PI;
}

std::optional<Eigen::Isometry3d> tag_pose(const DetectedTag& t, double size_m, const calibration::CameraIntrinsics& cam) {
  TagBundle b;
  b.name = "one tag";
  b.family = t.family;
  TagPlacement pl;
  pl.id = t.id;
  pl.size_m = size_m;
  b.tags = {pl};
  const BundlePose p = estimate_bundle_pose(b, cam, {t});
  if (!p.ok()) return std::nullopt;
  return p.T_cam_body;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)];
}

// One decode's result on one image.
struct Side {
  int found = 0;                      // references matched
  int spurious = 0;                   // detections matching no reference
  std::vector<double> ref_px;         // corner offset to the reference, px
  std::vector<double> t_mm, r_deg;    // pose error against the reference pose
};

// Old against new on one image: the decodes compared with each other and with the reference.
struct Compare {
  Side old_side, new_side, y_side;
  int both = 0, only_old = 0, only_new = 0;  // detections matched between the two decodes
  std::vector<double> diff_px;               // per matched tag, max corner difference old-new
  std::vector<double> diff_y_px;             // same, new against the Y plane
};

Side score(const std::vector<DetectedTag>& det, const Case& c) {
  Side s;
  std::vector<bool> used(det.size(), false);
  for (const Ref& r : c.refs) {
    const int i = match(det, r.id, r.corners, used);
    if (i < 0) continue;
    ++s.found;
    const DetectedTag& t = det[static_cast<std::size_t>(i)];
    for (int k = 0; k < 4; ++k) s.ref_px.push_back((t.corners_px[k] - r.corners[k]).norm());
    if (c.cam && r.T_cam_tag) {
      if (auto T = tag_pose(t, r.size_m, *c.cam)) {
        s.t_mm.push_back((T->translation() - r.T_cam_tag->translation()).norm() * 1e3);
        s.r_deg.push_back(rot_deg(T->linear(), r.T_cam_tag->linear()));
      }
    }
  }
  for (bool u : used) s.spurious += u ? 0 : 1;
  return s;
}

// Matches b's detections to a's (same id, centre within half a side).
void pair_up(const std::vector<DetectedTag>& a, const std::vector<DetectedTag>& b, int& both, int& only_a,
             int& only_b, std::vector<double>& diff) {
  std::vector<bool> used(b.size(), false);
  for (const DetectedTag& t : a) {
    const int i = match(b, t.id, t.corners_px, used);
    if (i < 0) {
      ++only_a;
      continue;
    }
    ++both;
    diff.push_back(max_corner_px(t.corners_px, b[static_cast<std::size_t>(i)].corners_px));
  }
  for (bool u : used) only_b += u ? 0 : 1;
}

TagDetector make_detector(TagFamilyId f, CameraResponse resp) {
  TagDetectorOptions o = TrackerOptions{}.detector;  // the tracker's: decimation 2, 7 candidates, refine
  o.families = {f};
  o.response = resp;
  auto d = TagDetector::create(o);
  EXPECT_TRUE(d.ok()) << d.error();
  return std::move(d).value();
}

std::vector<DetectedTag> detect(TagDetector& det, const cv::Mat& gray) {
  auto r = det.detect(gray);
  EXPECT_TRUE(r.ok()) << r.error();
  return r.ok() ? *r : std::vector<DetectedTag>{};
}

// Mean corner offset of a detection to the reference it matches (by position), or NAN.
double ref_error_px(const DetectedTag& t, const Case& c) {
  for (const Ref& r : c.refs) {
    if (r.id >= 0 && r.id != t.id) continue;
    if ((centre(r.corners) - centre(t.corners_px)).norm() > 0.5 * (r.corners[1] - r.corners[0]).norm()) continue;
    double e = 0;
    for (int k = 0; k < 4; ++k) e += (t.corners_px[k] - r.corners[k]).norm() / 4;
    return e;
  }
  return NAN;
}

// The figures of every case of a test, for its assertions and its summary line.
struct Worst {
  int only_old = 0, only_new = 0, cases = 0, found_old = 0, found_new = 0, refs = 0;
  double case_median_px = 0;  // worst per-case median of the old-new corner difference
  double diff_px = 0, diff_y_px = 0, ref_worse_px = -1e9;
  // Pose error medians (where the set has poses): the worst new - old, mm and relative, and the
  // worst excess over the bound new <= 1.03 old + 0.1 mm.
  double t_worse_mm = -1e9, t_worse_rel = -1e9, t_excess_mm = -1e9;
  // Tags whose corners moved more than kLargeDiffPx between the decodes, and of those, the ones
  // the new decode put further from the reference (mean corner offset + 0.1 px).
  int large = 0, large_worse = 0;
  std::vector<double> all_diff_px;
};
constexpr double kLargeDiffPx = 0.5;

void print_header() {
  std::printf(
      "\n| image | JPEG | response | tags old / new / Y (of the reference's) | only old / only new | corner diff "
      "old-new px p50 / p95 / max | new-Y max px | corners vs ref px median old / new / Y | pose mm median old / new "
      "/ Y | grey old-new max / mean | grey new-Y max / mean | colour shown max / mean |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
}

std::string three(const std::vector<double>& a, const std::vector<double>& b, const std::vector<double>& c,
                  const char* f) {
  if (a.empty() && b.empty() && c.empty()) return "—";
  char buf[96];
  std::snprintf(buf, sizeof buf, f, quantile(a, 0.5), quantile(b, 0.5), quantile(c, 0.5));
  return buf;
}

// Runs one JPEG through the three decodes and the tracker's detector with each response (unknown ->
// linear, a measured sRGB station -> srgb); prints a row per response and adds to `w`.
void run_case(const Case& c, const std::string& jpeg_label, const Bytes& jpg, Worst& w, bool expect_yuyv = true) {
  ASSERT_FALSE(jpg.empty()) << c.name << " " << jpeg_label;
  const Greys g = decode_three(jpg);
  if (expect_yuyv) {
    EXPECT_EQ(g.yuyv_type, CV_8UC2) << c.name << " " << jpeg_label;
  }
  const auto [on_max, on_mean] = grey_diff(g.old_gray, g.yuyv_gray);
  const auto [ny_max, ny_mean] = grey_diff(g.yuyv_gray, g.y_plane);
  for (CameraResponse resp : {CameraResponse::kLinear, CameraResponse::kSrgb}) {
    SCOPED_TRACE(c.name + " " + jpeg_label + " " + camera_response_name(resp));
    TagDetector det = make_detector(c.family, resp);
    const std::vector<DetectedTag> d_old = detect(det, g.old_gray), d_new = detect(det, g.yuyv_gray),
                                   d_y = detect(det, g.y_plane);
    Compare cm;
    cm.old_side = score(d_old, c);
    cm.new_side = score(d_new, c);
    cm.y_side = score(d_y, c);
    pair_up(d_old, d_new, cm.both, cm.only_old, cm.only_new, cm.diff_px);
    int b2 = 0, o2 = 0, n2 = 0;
    pair_up(d_y, d_new, b2, o2, n2, cm.diff_y_px);
    // Tags that moved a lot: which decode is nearer the reference?
    {
      std::vector<bool> used(d_new.size(), false);
      for (const DetectedTag& t : d_old) {
        const int i = match(d_new, t.id, t.corners_px, used);
        if (i < 0) continue;
        const DetectedTag& u = d_new[static_cast<std::size_t>(i)];
        if (max_corner_px(t.corners_px, u.corners_px) <= kLargeDiffPx) continue;
        ++w.large;
        const double eo = ref_error_px(t, c), en = ref_error_px(u, c);
        std::printf("  [ moved ] tag %d at (%.0f, %.0f), side %.1f px: corners moved up to %.2f px; mean offset to "
                    "the reference %.2f px old, %.2f px new\n",
                    t.id, centre(t.corners_px).x(), centre(t.corners_px).y(), (t.corners_px[1] - t.corners_px[0]).norm(),
                    max_corner_px(t.corners_px, u.corners_px), eo, en);
        if (!(en <= eo + 0.1)) ++w.large_worse;
      }
    }
    const double dmax = quantile(cm.diff_px, 1.0), dymax = quantile(cm.diff_y_px, 1.0);
    std::printf("| %s | %s | %s | %d / %d / %d of %zu | %d / %d | %.3f / %.3f / %.3f | %.3f | %s | %s | %d / %.2f | %d / %.2f | %d / %.2f |\n",
                c.name.c_str(), jpeg_label.c_str(), camera_response_name(resp), cm.old_side.found, cm.new_side.found,
                cm.y_side.found, c.refs.size(), cm.only_old, cm.only_new, quantile(cm.diff_px, 0.5),
                quantile(cm.diff_px, 0.95), dmax, dymax,
                three(cm.old_side.ref_px, cm.new_side.ref_px, cm.y_side.ref_px, "%.3f / %.3f / %.3f").c_str(),
                three(cm.old_side.t_mm, cm.new_side.t_mm, cm.y_side.t_mm, "%.2f / %.2f / %.2f").c_str(), on_max,
                on_mean, ny_max, ny_mean, g.colour_max, g.colour_mean);
    ++w.cases;
    w.only_old += cm.only_old;
    w.only_new += cm.only_new;
    w.found_old += cm.old_side.found;
    w.found_new += cm.new_side.found;
    w.refs += static_cast<int>(c.refs.size());
    if (!cm.diff_px.empty()) w.case_median_px = std::max(w.case_median_px, quantile(cm.diff_px, 0.5));
    if (!cm.diff_px.empty()) w.diff_px = std::max(w.diff_px, dmax);
    if (!cm.diff_y_px.empty()) w.diff_y_px = std::max(w.diff_y_px, dymax);
    w.all_diff_px.insert(w.all_diff_px.end(), cm.diff_px.begin(), cm.diff_px.end());
    if (!cm.old_side.ref_px.empty() && !cm.new_side.ref_px.empty())
      w.ref_worse_px = std::max(w.ref_worse_px, quantile(cm.new_side.ref_px, 0.5) - quantile(cm.old_side.ref_px, 0.5));
    if (!cm.old_side.t_mm.empty() && !cm.new_side.t_mm.empty()) {
      const double o = quantile(cm.old_side.t_mm, 0.5), n = quantile(cm.new_side.t_mm, 0.5);
      w.t_worse_mm = std::max(w.t_worse_mm, n - o);
      w.t_worse_rel = std::max(w.t_worse_rel, n / o - 1);
      w.t_excess_mm = std::max(w.t_excess_mm, n - (1.03 * o + 0.1));
    }
    // The new default finds every reference tag the old decode finds.
    EXPECT_GE(cm.new_side.found, cm.old_side.found);
  }
  std::fflush(stdout);
}

// The bounds every set is held to (docs/BENCHMARKS.md, "Issue 28 session 19 — the MJPG decode on
// real photos", has the measured values they were set from, with their margins).
void expect_within_bounds(const char* what, const Worst& w, double max_px) {
  std::printf("[ mjpeg real ] %s: %d cases; reference tags found old %d, new %d of %d; detections only old %d, "
              "only new %d; corner diff old-new p50 %.3f, p95 %.3f, max %.3f px (worst case median %.3f); new-Y max "
              "%.3f px; moved > %.1f px: %d tags, %d of them further from the reference; new minus old: "
              "corners-vs-reference median worst %+.3f px, pose median worst %s\n",
              what, w.cases, w.found_old, w.found_new, w.refs, w.only_old, w.only_new, quantile(w.all_diff_px, 0.5),
              quantile(w.all_diff_px, 0.95), w.diff_px, w.case_median_px, w.diff_y_px, kLargeDiffPx, w.large,
              w.large_worse, w.ref_worse_px,
              w.t_worse_rel > -1e8 ? (std::to_string(w.t_worse_mm).substr(0, 6) + " mm, " +
                                      std::to_string(100 * w.t_worse_rel).substr(0, 5) + " %").c_str()
                                   : "— (no poses)");
  std::fflush(stdout);
  SCOPED_TRACE(what);
  ASSERT_GT(w.cases, 0);
  EXPECT_EQ(w.only_old, 0) << "the new decode missed a tag the old one found";
  EXPECT_GE(w.found_new, w.found_old);
  EXPECT_LT(w.case_median_px, 0.1);
  EXPECT_LT(quantile(w.all_diff_px, 0.95), 0.3);
  EXPECT_LT(w.diff_px, max_px);
  EXPECT_EQ(w.large_worse, 0) << "a tag the new decode moved by more than " << kLargeDiffPx
                              << " px is further from the reference";
  EXPECT_LT(w.ref_worse_px, 0.06);
  if (w.t_worse_rel > -1e8) {
    EXPECT_LT(w.t_excess_mm, 0.0) << "a median pose error above 1.03 x the old decode's + 0.1 mm";
  }
}

// ---- The sets ----

std::vector<std::pair<std::string, std::pair<int, int>>> uvc_encodings() {
  return {{"4:2:2 q80", {TJSAMP_422, 80}}, {"4:2:2 q95", {TJSAMP_422, 95}}, {"4:2:0 q80", {TJSAMP_420, 80}}};
}

const char* const kSwarmStems[] = {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c", "34139872896_defdb2f8d9_c"};

std::optional<Case> swarm_case(const char* stem) {
  Case c;
  c.name = std::string(stem).substr(0, 11);
  c.ref_kind = "libapriltag";
  if (!fs::exists(kSwarm / (std::string(stem) + ".jpg"))) return std::nullopt;
  for (const auto& s : test::read_swarm_refs(kSwarm / (std::string(stem) + ".txt"))) {
    Ref r;
    r.id = s.id;
    r.corners = s.corners;
    c.refs.push_back(r);
  }
  if (c.refs.empty()) return std::nullopt;
  return c;
}

// The Swarmathon photos: `own` their own bytes (as they are, and cropped losslessly to an even
// width), else re-encoded as a UVC camera would send them.
void run_swarmathon(bool own) {
  std::vector<std::pair<Case, Bytes>> photos;
  for (const char* stem : kSwarmStems)
    if (auto c = swarm_case(stem)) photos.push_back({*c, read_bytes(kSwarm / (std::string(stem) + ".jpg"))});
  if (photos.size() != 3) GTEST_SKIP() << kSwarm << " (three JPEGs and their reference corners) is absent";
  Worst w;
  print_header();
  for (const auto& [c, jpg] : photos) {
    int width = 0, height = 0, sub = 0, cs = 0;
    {
      tjhandle tj = tjInitDecompress();
      ASSERT_EQ(tjDecompressHeader3(tj, jpg.data(), jpg.size(), &width, &height, &sub, &cs), 0);
      tjDestroy(tj);
    }
    ASSERT_EQ(width % 2, 1) << "the photos are 799 px wide";
    const Bytes even = crop_to_even_width(jpg, width, height);
    if (own) {
      // As they are: an odd width, so the YUYV default hands on BGR (a YUYV row needs pixel pairs).
      MjpegDecoder dec(false);
      cv::Mat out;
      ASSERT_TRUE(dec.decode(jpg.data(), jpg.size(), MjpegOutput::kYuyv, out)) << dec.why();
      EXPECT_EQ(out.type(), CV_8UC3) << "an odd width now gives YUYV: update this test";
      run_case(c, "own bytes, 799 px (YUYV falls back to BGR)", jpg, w, false);
      run_case(c, "own bytes, lossless crop to 798 px", even, w);
    } else {
      const cv::Mat bgr = cv::imdecode(even, cv::IMREAD_COLOR);
      for (const auto& [label, e] : uvc_encodings())
        run_case(c, "re-encoded " + label, encode_uvc(bgr, e.first, e.second), w);
    }
  }
  // A tag's corners can jump where the refit is unstable (small, blurred tags): a grey level's
  // difference moved two tags of 34085369442 by 1.2-1.7 px with the sRGB refit (both nearer the
  // reference with the new decode; checked by large_worse). The max bound only catches worse.
  expect_within_bounds(own ? "Swarmathon photos, own bytes" : "Swarmathon photos, re-encoded", w, 2.5);
}

TEST(MjpegRealPhoto, SwarmathonPhotosOwnBytes) { run_swarmathon(true); }
TEST(MjpegRealPhoto, SwarmathonPhotosReencodedAsAUvcCamera) { run_swarmathon(false); }

std::optional<Case> visp_photo() {
  Case c;
  c.name = "ViSP AprilTag.pgm";
  c.ref_kind = "ViSP";
  c.cam = calibration::CameraIntrinsics{};
  c.cam->width = 640;
  c.cam->height = 480;
  c.cam->fx = 615.1674805;
  c.cam->fy = 615.1675415;
  c.cam->cx = 312.1889954;
  c.cam->cy = 243.4373779;
  std::ifstream det(kViSP / "ground_truth_detection.txt"), pose(kViSP / "ground_truth_pose.txt");
  if (!fs::exists(kViSP / "AprilTag.pgm") || !det || !pose) return std::nullopt;
  std::map<int, Ref> refs;
  std::string key;
  double v[4], u[4];
  // "36h11_id:_8" then (row, column) per corner, libapriltag's convention (+0.5 px).
  while (det >> key >> v[0] >> u[0] >> v[1] >> u[1] >> v[2] >> u[2] >> v[3] >> u[3]) {
    const int id = std::stoi(key.substr(key.rfind('_') + 1));
    Ref& r = refs[id];
    r.id = id;
    r.size_m = 0.053;
    for (int i = 0; i < 4; ++i) r.corners[static_cast<std::size_t>(i)] = Eigen::Vector2d(u[i] - 0.5, v[i] - 0.5);
  }
  double t[3], wv[3];
  while (pose >> key >> t[0] >> t[1] >> t[2] >> wv[0] >> wv[1] >> wv[2]) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotation_exp(Eigen::Vector3d(wv[0], wv[1], wv[2]));
    T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    // ViSP's tag frame (z out of the tag) to ours: a half turn about x.
    Eigen::Isometry3d F = Eigen::Isometry3d::Identity();
    F.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    refs[std::stoi(key.substr(key.rfind('_') + 1))].T_cam_tag = T * F;
  }
  for (auto& [id, r] : refs) c.refs.push_back(r);
  if (c.refs.size() != 12) return std::nullopt;
  return c;
}

// ViSP's rendered benchmark (real_image_sets_test.cpp says where the camera and sizes come from).
std::optional<Case> visp_render(const std::string& res, TagFamilyId family, fs::path& png) {
  const bool hd = res == "1920x1080";
  const std::string stem = family == TagFamilyId::kTag36h11 ? "tag36_11" : "tag41_12";
  const double scale = family == TagFamilyId::kTag36h11 ? 8.0 / 10 : 5.0 / 9;
  Case c;
  c.name = "ViSP render " + res + " " + tag_family_name(family);
  c.ref_kind = "truth";
  c.family = family;
  calibration::CameraIntrinsics k;
  k.width = hd ? 1920 : 640;
  k.height = hd ? 1080 : 480;
  k.fx = k.fy = hd ? 2100 : 700;
  k.cx = hd ? 959.5 : 319.5;
  k.cy = hd ? 539.5 : 239.5;
  c.cam = k;
  png = kViSP / "benchmark" / res / (stem + "_" + res + ".png");
  if (!fs::exists(png)) return std::nullopt;
  for (int id = 0; id < 5; ++id) {
    std::ifstream in(kViSP / "benchmark/640x480" / ("cMo_" + std::to_string(id) + ".txt"));
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int q = 0; q < 4; ++q) in >> M(r, q);
    if (!in) return std::nullopt;
    Ref r;
    r.id = id;
    r.size_m = (id < 3 ? 0.25 : 0.125) * scale;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = M.topLeftCorner<3, 3>();
    T.translation() = M.topRightCorner<3, 1>();
    Eigen::Isometry3d F = Eigen::Isometry3d::Identity();
    F.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    r.T_cam_tag = T * F;
    static const double sx[4] = {-1, 1, 1, -1}, sy[4] = {1, 1, -1, -1};
    for (int q = 0; q < 4; ++q) {
      const Eigen::Vector3d p = *r.T_cam_tag * Eigen::Vector3d(sx[q] * r.size_m / 2, sy[q] * r.size_m / 2, 0);
      r.corners[static_cast<std::size_t>(q)] = Eigen::Vector2d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy);
    }
    c.refs.push_back(r);
  }
  return c;
}

TEST(MjpegRealPhoto, ViSPPhotoAsAUvcCamera) {
  const std::optional<Case> photo = visp_photo();
  if (!photo) GTEST_SKIP() << kViSP << " (AprilTag.pgm and its reference) is absent: install visp-images-data";
  const cv::Mat grey = cv::imread((kViSP / "AprilTag.pgm").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(grey.empty());
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  Worst w;
  print_header();
  for (const auto& [label, e] : uvc_encodings()) run_case(*photo, label, encode_uvc(bgr, e.first, e.second), w);
  expect_within_bounds("ViSP photo", w, 0.25);
}

TEST(MjpegRealPhoto, ViSPRendersAsAUvcCamera) {
  Worst w;
  print_header();
  for (const std::string res : {"640x480", "1920x1080"})
    for (TagFamilyId f : {TagFamilyId::kTag36h11, TagFamilyId::kStandard41h12}) {
      fs::path png;
      const std::optional<Case> c = visp_render(res, f, png);
      if (!c) continue;
      const cv::Mat bgr = cv::imread(png.string(), cv::IMREAD_COLOR);
      ASSERT_FALSE(bgr.empty()) << png;
      for (const auto& [label, e] : uvc_encodings()) run_case(*c, label, encode_uvc(bgr, e.first, e.second), w);
    }
  if (w.cases == 0) GTEST_SKIP() << kViSP / "benchmark" << " is absent: install visp-images-data";
  expect_within_bounds("ViSP renders", w, 0.25);
}

// The chessboard's inner corners (calibration::detect_chessboard, the camera step's finder) on the
// old and the new grey. The finder may start the 9x6 grid at either end: corners are matched to
// the nearest of the other view's. Where the two disagree, the old grey is given uniform
// {-1, 0, +1} noise (the size of the new decode's rounding) 8 times to see whether the finder is
// that fragile on the view whatever the decode.
void run_chessboards(const std::vector<std::string>& names, bool reencode) {
  if (!fs::exists(kOpenCV / "left01.jpg"))
    GTEST_SKIP() << kOpenCV << "/left01.jpg is absent: install the Debian package opencv-doc";
  auto board = parse_board_spec("chessboard:9x6:25");
  ASSERT_TRUE(board.ok()) << board.error();
  auto det = BoardDetector::create(*board);
  ASSERT_TRUE(det.ok()) << det.error();
  int views = 0, found_old = 0, found_new = 0, found_y = 0, only_old = 0, differ = 0;
  std::vector<double> diff, diff_y;
  auto nearest = [](const calibration::BoardView& a, const calibration::BoardView& b, std::vector<double>& out) {
    for (const Eigen::Vector2d& p : a.image_points) {
      double best = 1e9;
      for (const Eigen::Vector2d& q : b.image_points) best = std::min(best, (p - q).norm());
      out.push_back(best);
    }
  };
  for (const std::string& name : names) {
    if (!fs::exists(kOpenCV / name)) continue;
    Bytes jpg = read_bytes(kOpenCV / name);
    if (reencode) jpg = encode_uvc(cv::imdecode(jpg, cv::IMREAD_COLOR), TJSAMP_422, 80);
    const Greys g = decode_three(jpg);
    EXPECT_EQ(g.yuyv_type, CV_8UC2) << name;
    auto a = det->detect(g.old_gray, name), b = det->detect(g.yuyv_gray, name), y = det->detect(g.y_plane, name);
    ++views;
    found_old += a.ok();
    found_new += b.ok();
    found_y += y.ok();
    if (a.ok() && !b.ok()) ++only_old;
    if (a.ok() && b.ok()) {
      EXPECT_EQ(a->image_points.size(), b->image_points.size()) << name;
      std::vector<double> d, dy;
      nearest(*a, *b, d);
      if (y.ok()) nearest(*y, *b, dy);
      if (quantile(d, 1.0) > 0.1) {
        ++differ;
        int bad = 0, lost = 0;
        cv::RNG rng(7);
        for (int k = 0; k < 8; ++k) {
          cv::Mat n(g.old_gray.size(), CV_16S), noisy;
          rng.fill(n, cv::RNG::UNIFORM, -1, 2);
          cv::Mat sum;
          g.old_gray.convertTo(sum, CV_16S);
          sum += n;
          sum.convertTo(noisy, CV_8U);
          auto c = det->detect(noisy, name);
          if (!c.ok())
            ++lost;
          else if (calibration::board_homography_rms_px(*c) > 3)
            ++bad;
        }
        std::printf("  [ board ] %s: corners old-new p50 %.4f max %.2f px, new-Y max %.2f px; homography rms old %.2f, "
                    "new %.2f px; the old grey + {-1,0,1} noise, 8 draws: %d boards with rms > 3 px, %d not found\n",
                    name.c_str(), quantile(d, 0.5), quantile(d, 1.0), quantile(dy, 1.0), calibration::board_homography_rms_px(*a),
                    calibration::board_homography_rms_px(*b), bad, lost);
      }
      diff.insert(diff.end(), d.begin(), d.end());
    }
    if (y.ok() && b.ok()) nearest(*y, *b, diff_y);
  }
  ASSERT_GT(views, 0);
  std::printf("\n| photos | JPEG | views | boards old / new / Y | views whose corners differ > 0.1 px | corner diff "
              "old-new px p50 / p95 / max | new-Y max px |\n|---|---|---|---|---|---|---|\n"
              "| OpenCV %s..%s | %s | %d | %d / %d / %d | %d | %.4f / %.4f / %.2f | %.2f |\n",
              names.front().c_str(), names.back().c_str(), reencode ? "re-encoded 4:2:2 q80" : "own bytes (grey JPEG)",
              views, found_old, found_new, found_y, differ, quantile(diff, 0.5), quantile(diff, 0.95),
              quantile(diff, 1.0), quantile(diff_y, 1.0));
  std::fflush(stdout);
  EXPECT_EQ(only_old, 0);
  EXPECT_GE(found_new, found_old);
  EXPECT_LT(quantile(diff, 0.95), 0.05);
  // OpenCV's sector-based finder puts a whole column of corners 20-40 px off on right02 and
  // right04 when their grey changes by one level (the old grey with such noise: 1 and 5 bad boards
  // in 8 draws); measured: 2 of 26 views. Elsewhere the corners agree within 0.05 px.
  EXPECT_LE(differ, 3);
}

std::vector<std::string> chessboard_names(int per_side) {
  std::vector<std::string> n;
  for (const char* side : {"left", "right"})
    for (int i = 1, k = 0; i <= 14 && k < per_side; ++i) {
      if (i == 10) continue;  // there is no left10/right10
      char b[32];
      std::snprintf(b, sizeof b, "%s%02d.jpg", side, i);
      n.push_back(b);
      ++k;
    }
  return n;
}

// Two views in the default suite (the finder takes ~1 s a view on a loaded machine), all 26 and
// their UVC re-encodings in the long run.
TEST(MjpegRealPhoto, ChessboardPhotosOwnBytesTwoViews) { run_chessboards(chessboard_names(1), false); }
TEST(MjpegRealPhoto, ChessboardPhotosAllViews) {
  run_chessboards(chessboard_names(13), false);
  run_chessboards(chessboard_names(13), true);
}

}  // namespace
}  // namespace dentar::ar
