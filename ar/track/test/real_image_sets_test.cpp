// The tracker's detection and per-tag pose on every public image set with
// known geometry found on the build machine (issue 16, "Real images"),
// against an anchor run on the same images in the same process: plain
// libapriltag (apriltag_detector_create() with its defaults, the family
// created directly, no dentar code) + cv::solvePnP(SOLVEPNP_IPPE_SQUARE).
//
// The sets (Debian package visp-images-data 3.5.0-1, GPL-2; provenance in
// tests/data_provenance.md), read in place; each test GTEST_SKIPs when its
// files are absent:
//  1. AprilTag/AprilTag.pgm: a real 640x480 photograph of twelve tag36h11
//     tags (ids 8-19, 53 mm) printed on one sheet of paper lying on a desk.
//     Reference: ViSP's own detection (ground_truth_detection.txt) and pose
//     estimates (ground_truth_pose.txt) - estimates, not truth. What is true
//     is that the twelve tags lie on one sheet: the coplanarity of the
//     recovered tag poses is the geometric check.
//  2. AprilTag/benchmark/640x480 and 1920x1080: *rendered* images (a
//     checkerboard floor under a black sky, five tags floating above it;
//     no sensor noise), one per family. Only tag36h11 and
//     tagStandard41h12 are families the tracker supports (TagFamilyId); the
//     six others (tag16h5, tagCircle21h7, tag25h9, tagCustom48h12,
//     tagCircle49h12, tagStandard52h13) are skipped. Facts taken from
//     ViSP's catchAprilTag.cpp / perfApriltagDetection.cpp (read, not
//     copied): camera fx = fy = 700, principal point (320, 240) at 640x480
//     and fx = fy = 2100, (960, 540) at 1920x1080 (the same horizontal field
//     of view, 49.1 deg), no distortion; the whole printed tag is 0.25 m for
//     ids 0-2 and 0.125 m for ids 3-4, so the border square (libapriltag's
//     tag size) is 8/10 of that for tag36h11 and 5/9 for tagStandard41h12;
//     cMo_<id>.txt is the pose of tag <id> in ViSP's tag frame (x right, y
//     up, z out of the tag: ours rotated by pi about x), the pose the scene
//     was rendered with. corners_<family>.txt are ViSP's (libapriltag's)
//     detections at 640x480. The renderer's principal point is the image
//     centre in continuous coordinates (pixel i spans [i, i + 1]): 320 is
//     319.5 in OpenCV's convention; the projected cMo corners agree with
//     ViSP's corners to a few tenths of a pixel with that reading and would
//     be 0.5 px off with the other.
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagStandard41h12.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/ar/tracker.h"
#include "swarm_photos.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;

const fs::path kViSP = "/usr/share/visp-images-data/ViSP-images/AprilTag";
constexpr int kTimingReps = 40;  // p99 of 40 by nearest rank is the max
constexpr double kPi = 3.14159265358979323846;

using Corners = std::array<Eigen::Vector2d, 4>;

// ---- The reference ----

struct TagRef {
  int id = 0;
  double size_m = 0;             // border square side
  std::optional<Corners> truth;  // render truth (projected pose), OpenCV px, libapriltag order
  std::optional<Corners> visp;   // ViSP's detection, OpenCV px
  std::optional<Eigen::Isometry3d> T_cam_tag;  // reference pose, our (libapriltag's) tag frame
};

struct ImageCase {
  std::string set;    // "photo", "render 640x480", ...
  std::string label;  // "tag36h11"
  fs::path path;
  TagFamilyId family = TagFamilyId::kTag36h11;
  calibration::CameraIntrinsics cam;  // OpenCV pixel convention
  std::vector<TagRef> tags;
  const TagRef* find(int id) const {
    for (const TagRef& t : tags)
      if (t.id == id) return &t;
    return nullptr;
  }
};

// ViSP's tag frame (z out of the tag) to ours (libapriltag's: y down, z into
// the tag): a half turn about x. T_cam_ours = T_cam_visp * Rx(pi).
Eigen::Isometry3d from_visp_frame(const Eigen::Isometry3d& T_cam_visp) {
  Eigen::Isometry3d F = Eigen::Isometry3d::Identity();
  F.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return T_cam_visp * F;
}

calibration::CameraIntrinsics pinhole(int w, int h, double fx, double fy, double cx, double cy) {
  calibration::CameraIntrinsics c;
  c.width = w;
  c.height = h;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  return c;
}

Eigen::Vector2d project(const calibration::CameraIntrinsics& c, const Eigen::Vector3d& p) {
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

// The tag's border-square corners in our tag frame, libapriltag's order.
Eigen::Vector3d tag_corner(double size_m, int k) {
  const double h = size_m / 2;
  static const double sx[4] = {-1, 1, 1, -1}, sy[4] = {1, 1, -1, -1};
  return {sx[k] * h, sy[k] * h, 0};
}

// "36h11_id:_8" -> 8.
int id_of(const std::string& key) { return std::stoi(key.substr(key.rfind('_') + 1)); }

std::optional<ImageCase> load_photo() {
  ImageCase c;
  c.set = "photo 640x480";
  c.label = "tag36h11 (12)";
  c.path = kViSP / "AprilTag.pgm";
  c.family = TagFamilyId::kTag36h11;
  c.cam = pinhole(640, 480, 615.1674805, 615.1675415, 312.1889954, 243.4373779);
  std::ifstream det(kViSP / "ground_truth_detection.txt"), pose(kViSP / "ground_truth_pose.txt");
  if (!fs::exists(c.path) || !det || !pose) return std::nullopt;
  std::map<int, TagRef> refs;
  std::string key;
  double v[4], u[4];
  // Rows: (row, column) per corner, libapriltag's convention (+0.5 px).
  while (det >> key >> v[0] >> u[0] >> v[1] >> u[1] >> v[2] >> u[2] >> v[3] >> u[3]) {
    TagRef& r = refs[id_of(key)];
    r.id = id_of(key);
    r.size_m = 0.053;
    Corners k;
    for (int i = 0; i < 4; ++i) k[i] = Eigen::Vector2d(u[i] - 0.5, v[i] - 0.5);
    r.visp = k;
  }
  double t[3], w[3];
  while (pose >> key >> t[0] >> t[1] >> t[2] >> w[0] >> w[1] >> w[2]) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotation_exp(Eigen::Vector3d(w[0], w[1], w[2]));
    T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    refs[id_of(key)].T_cam_tag = from_visp_frame(T);
  }
  for (auto& [id, r] : refs) c.tags.push_back(r);
  return c;
}

// The rendered benchmark: five tags, ids 0..4, poses cMo_<id>.txt.
std::optional<ImageCase> load_render(const std::string& res, TagFamilyId family) {
  const bool hd = res == "1920x1080";
  const std::string stem = family == TagFamilyId::kTag36h11 ? "tag36_11" : "tag41_12";
  const double scale = family == TagFamilyId::kTag36h11 ? 8.0 / 10 : 5.0 / 9;
  ImageCase c;
  c.set = "render " + res;
  c.label = tag_family_name(family);
  c.path = kViSP / "benchmark" / res / (stem + "_" + res + ".png");
  c.family = family;
  c.cam = hd ? pinhole(1920, 1080, 2100, 2100, 959.5, 539.5)
             : pinhole(640, 480, 700, 700, 319.5, 239.5);
  if (!fs::exists(c.path)) return std::nullopt;
  std::map<int, Corners> visp;
  if (!hd) {
    std::ifstream in(kViSP / "benchmark/640x480" / ("corners_" + stem + ".txt"));
    if (!in) return std::nullopt;
    int id;
    double p[8];
    // Rows: id, then x y per corner, libapriltag's convention (+0.5 px).
    while (in >> id >> p[0] >> p[1] >> p[2] >> p[3] >> p[4] >> p[5] >> p[6] >> p[7]) {
      Corners k;
      for (int i = 0; i < 4; ++i) k[i] = Eigen::Vector2d(p[2 * i] - 0.5, p[2 * i + 1] - 0.5);
      visp[id] = k;
    }
  }
  for (int id = 0; id < 5; ++id) {
    std::ifstream in(kViSP / "benchmark/640x480" / ("cMo_" + std::to_string(id) + ".txt"));
    if (!in) return std::nullopt;
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int k = 0; k < 4; ++k) in >> M(r, k);
    if (!in) return std::nullopt;
    TagRef r;
    r.id = id;
    r.size_m = (id < 3 ? 0.25 : 0.125) * scale;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = M.topLeftCorner<3, 3>();
    T.translation() = M.topRightCorner<3, 1>();
    r.T_cam_tag = from_visp_frame(T);
    Corners k;
    for (int i = 0; i < 4; ++i) k[i] = project(c.cam, *r.T_cam_tag * tag_corner(r.size_m, i));
    r.truth = k;
    if (visp.count(id)) r.visp = visp[id];
    c.tags.push_back(r);
  }
  return c;
}

// ---- The pipelines ----

struct TagResult {
  int id = 0;
  Corners corners;  // OpenCV px
  Eigen::Isometry3d T_cam_tag = Eigen::Isometry3d::Identity();
  bool pose_ok = false;
};

Eigen::Isometry3d iso_from_rt(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) T.linear()(i, j) = R(i, j);
    T.translation()(i) = tvec[i];
  }
  return T;
}

// The anchor: libapriltag exactly as a newcomer would use it, then OpenCV's
// square-tag PnP. libapriltag's corners are shifted by -0.5 px into OpenCV's
// convention (that is a convention, not a correction: without it every
// pose is off by half a pixel's worth).
class PlainAnchor {
 public:
  PlainAnchor(TagFamilyId f, float decimate) : family_id_(f) {
    tf_ = f == TagFamilyId::kTag36h11 ? tag36h11_create() : tagStandard41h12_create();
    td_ = apriltag_detector_create();
    apriltag_detector_add_family(td_, tf_);
    if (decimate > 0) td_->quad_decimate = decimate;
  }
  ~PlainAnchor() {
    apriltag_detector_destroy(td_);
    if (family_id_ == TagFamilyId::kTag36h11)
      tag36h11_destroy(tf_);
    else
      tagStandard41h12_destroy(tf_);
  }
  PlainAnchor(const PlainAnchor&) = delete;
  PlainAnchor& operator=(const PlainAnchor&) = delete;
  float decimation() const { return td_->quad_decimate; }

  std::vector<TagResult> run(const cv::Mat& gray, const ImageCase& c) {
    image_u8_t im = {gray.cols, gray.rows, static_cast<int32_t>(gray.step),
                     const_cast<uint8_t*>(gray.ptr<uint8_t>(0))};
    zarray_t* dets = apriltag_detector_detect(td_, &im);
    const cv::Matx33d K(c.cam.fx, 0, c.cam.cx, 0, c.cam.fy, c.cam.cy, 0, 0, 1);
    std::vector<TagResult> out;
    for (int i = 0; i < zarray_size(dets); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(dets, i, &d);
      TagResult r;
      r.id = d->id;
      std::vector<cv::Point2d> img;
      for (int k = 0; k < 4; ++k) {
        r.corners[k] = Eigen::Vector2d(d->p[k][0] - 0.5, d->p[k][1] - 0.5);
        img.emplace_back(r.corners[k].x(), r.corners[k].y());
      }
      if (const TagRef* ref = c.find(d->id)) {
        const double h = ref->size_m / 2;
        const std::vector<cv::Point3d> obj = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
        cv::Vec3d rvec, tvec;
        r.pose_ok =
            cv::solvePnP(obj, img, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE);
        if (r.pose_ok) r.T_cam_tag = iso_from_rt(rvec, tvec);
      }
      out.push_back(r);
    }
    apriltag_detections_destroy(dets);
    return out;
  }

 private:
  TagFamilyId family_id_;
  apriltag_family_t* tf_ = nullptr;
  apriltag_detector_t* td_ = nullptr;
};

enum class PoseMode {
  kTagPoses,  // estimate_tag_poses: IPPE_SQUARE, the lower-RMS solution
  kBundle,    // estimate_bundle_pose on a one-tag bundle: the tracker's path (IPPE seeds + LM)
};

// Ours: TagDetector with the tracker's default detector options (sRGB
// response, decimation 2, edge refinement) unless told otherwise.
class Ours {
 public:
  Ours(TagFamilyId f, double decimation, CameraResponse response, PoseMode mode) : mode_(mode) {
    TagDetectorOptions o = TrackerOptions{}.detector;
    o.families = {f};
    o.decimation = decimation;
    o.response = response;
    auto d = TagDetector::create(o);
    EXPECT_TRUE(d.ok()) << d.error();
    if (d.ok()) det_ = std::make_unique<TagDetector>(std::move(d).value());
  }
  bool ok() const { return det_ != nullptr; }

  std::vector<TagResult> run(const cv::Mat& gray, const ImageCase& c) {
    std::vector<TagResult> out;
    auto found = det_->detect(gray);
    if (!found.ok()) {
      ADD_FAILURE() << found.error();
      return out;
    }
    for (const DetectedTag& t : *found) {
      TagResult r;
      r.id = t.id;
      r.corners = t.corners_px;
      if (const TagRef* ref = c.find(t.id)) {
        if (mode_ == PoseMode::kTagPoses) {
          const std::vector<TagPose> p = estimate_tag_poses({t}, c.cam, ref->size_m);
          if (p.size() == 1 && p[0].ok) {
            r.pose_ok = true;
            r.T_cam_tag = p[0].T_cam_tag;
          }
        } else {
          TagBundle b;
          b.name = "one tag";
          b.family = t.family;
          TagPlacement pl;
          pl.id = t.id;
          pl.size_m = ref->size_m;
          b.tags = {pl};
          const BundlePose p = estimate_bundle_pose(b, c.cam, {t});
          if (p.ok()) {
            r.pose_ok = true;
            r.T_cam_tag = p.T_cam_body;
          }
        }
      }
      out.push_back(r);
    }
    return out;
  }

 private:
  PoseMode mode_;
  std::unique_ptr<TagDetector> det_;
};

struct Pipeline {
  std::string name;
  bool anchor = false;
  double decimation = 2;
  std::function<std::vector<TagResult>(const cv::Mat&, const ImageCase&)> run;
};

// The pipelines compared, built for one family. The anchor at libapriltag's
// default decimation (2) comes first: timing ratios are against the anchor
// with the same decimation.
std::vector<Pipeline> make_pipelines(TagFamilyId f) {
  std::vector<Pipeline> p;
  auto add_anchor = [&](const std::string& name, float dec) {
    auto a = std::make_shared<PlainAnchor>(f, dec);
    p.push_back({name, true, a->decimation(),
                 [a](const cv::Mat& g, const ImageCase& c) { return a->run(g, c); }});
  };
  auto add_ours = [&](const std::string& name, double dec, CameraResponse resp, PoseMode m) {
    auto o = std::make_shared<Ours>(f, dec, resp, m);
    if (!o->ok()) return;
    p.push_back(
        {name, false, dec, [o](const cv::Mat& g, const ImageCase& c) { return o->run(g, c); }});
  };
  add_anchor("anchor d2 (libapriltag defaults + IPPE)", 0);
  add_ours("ours d2 (tracker default: sRGB)", 2, CameraResponse::kSrgb, PoseMode::kTagPoses);
  add_ours("ours d2, one-tag bundle pose", 2, CameraResponse::kSrgb, PoseMode::kBundle);
  add_ours("ours d2, linear response", 2, CameraResponse::kLinear, PoseMode::kTagPoses);
  add_anchor("anchor d1", 1);
  add_ours("ours d1 (sRGB)", 1, CameraResponse::kSrgb, PoseMode::kTagPoses);
  return p;
}

// ---- Measuring ----

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  // Nearest rank.
  const auto i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  return v[std::min(v.size() - 1, std::max<std::size_t>(0, i))];
}
double median(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  const std::size_t n = s.size();
  return n % 2 ? s[n / 2] : 0.5 * (s[n / 2 - 1] + s[n / 2]);
}
double maxv(const std::vector<double>& v) {
  return v.empty() ? NAN : *std::max_element(v.begin(), v.end());
}

double rotation_deg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  const double c = std::clamp(((A.transpose() * B).trace() - 1) / 2, -1.0, 1.0);
  return std::acos(c) * 180 / kPi;
}

struct Measured {
  int found = 0, expected = 0, spurious = 0;
  std::vector<double> corner_truth_px, corner_visp_px, t_mm, rot_deg, time_ms;
  // Against the truth (renders) or ViSP's corners (photo): the mean corner
  // offset, its component away from the tag's centre (> 0: the quad came
  // out larger), and the tags' distance error in % (< 0: nearer).
  Eigen::Vector2d mean_offset_px = Eigen::Vector2d::Zero();
  std::vector<double> outward_px, range_pct;
  std::vector<TagResult> tags;  // the accuracy run's output
};

// Coplanarity of tag poses (the photo's sheet): plane through the tag
// centres (least squares), centre distances to it and the tags' normals'
// angle to its normal.
struct Planarity {
  double centre_rms_mm = NAN, centre_max_mm = NAN, normal_median_deg = NAN, normal_max_deg = NAN;
};
Planarity planarity(const std::vector<Eigen::Isometry3d>& poses) {
  Planarity p;
  if (poses.size() < 4) return p;
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (const auto& T : poses) m += T.translation() / static_cast<double>(poses.size());
  Eigen::MatrixXd A(poses.size(), 3);
  for (std::size_t i = 0; i < poses.size(); ++i)
    A.row(i) = (poses[i].translation() - m).transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector3d n = svd.matrixV().col(2);
  std::vector<double> d, a;
  double ss = 0;
  for (const auto& T : poses) {
    const double di = std::abs(n.dot(T.translation() - m)) * 1e3;
    d.push_back(di);
    ss += di * di;
    const double c = std::min(1.0, std::abs(n.dot(T.linear().col(2))));
    a.push_back(std::acos(c) * 180 / kPi);
  }
  p.centre_rms_mm = std::sqrt(ss / static_cast<double>(d.size()));
  p.centre_max_mm = maxv(d);
  p.normal_median_deg = median(a);
  p.normal_max_deg = maxv(a);
  return p;
}

std::vector<Measured> measure(const ImageCase& c, const cv::Mat& gray,
                              std::vector<Pipeline>& pipes) {
  std::vector<Measured> out(pipes.size());
  for (std::size_t i = 0; i < pipes.size(); ++i) {
    Measured& m = out[i];
    m.tags = pipes[i].run(gray, c);  // the accuracy run (untimed, also a warm-up)
    m.expected = static_cast<int>(c.tags.size());
    std::map<int, int> seen;
    int n_off = 0;
    auto outward = [&](const Corners& r, const Corners& ref) {
      Eigen::Vector2d ctr = Eigen::Vector2d::Zero();
      for (const auto& q : ref) ctr += q / 4;
      for (int k = 0; k < 4; ++k)
        m.outward_px.push_back((r[k] - ref[k]).dot((ref[k] - ctr).normalized()));
    };
    for (const TagResult& r : m.tags) {
      const TagRef* ref = c.find(r.id);
      if (!ref) {
        ++m.spurious;
        continue;
      }
      if (seen[r.id]++) continue;  // a duplicate: counted once
      ++m.found;
      for (int k = 0; k < 4; ++k) {
        if (ref->truth) {
          m.corner_truth_px.push_back((r.corners[k] - (*ref->truth)[k]).norm());
          m.mean_offset_px += r.corners[k] - (*ref->truth)[k];
          ++n_off;
        } else if (ref->visp) {
          m.mean_offset_px += r.corners[k] - (*ref->visp)[k];
          ++n_off;
        }
        if (ref->visp) m.corner_visp_px.push_back((r.corners[k] - (*ref->visp)[k]).norm());
      }
      if (ref->truth)
        outward(r.corners, *ref->truth);
      else if (ref->visp)
        outward(r.corners, *ref->visp);
      if (ref->T_cam_tag && r.pose_ok) {
        m.t_mm.push_back((r.T_cam_tag.translation() - ref->T_cam_tag->translation()).norm() * 1e3);
        m.rot_deg.push_back(rotation_deg(r.T_cam_tag.linear(), ref->T_cam_tag->linear()));
        m.range_pct.push_back(
            100 * (r.T_cam_tag.translation().norm() / ref->T_cam_tag->translation().norm() - 1));
      }
    }
    if (n_off) m.mean_offset_px /= n_off;
  }
  // Timing: the pipelines interleaved, the order rotated every repetition,
  // so that load from the other work on the machine falls on all alike.
  for (int rep = 0; rep < kTimingReps; ++rep)
    for (std::size_t k = 0; k < pipes.size(); ++k) {
      const std::size_t i = (k + static_cast<std::size_t>(rep)) % pipes.size();
      const auto t0 = std::chrono::steady_clock::now();
      const std::vector<TagResult> r = pipes[i].run(gray, c);
      const auto t1 = std::chrono::steady_clock::now();
      out[i].time_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      EXPECT_EQ(r.size(), out[i].tags.size()) << pipes[i].name << ": not deterministic";
    }
  return out;
}

std::string fmt2(const std::vector<double>& v, const char* f = "%.3f / %.3f") {
  if (v.empty()) return "—";
  char b[64];
  std::snprintf(b, sizeof b, f, median(v), maxv(v));
  return b;
}

void print_header() {
  std::printf(
      "\n| set | image | pipeline | tags found / expected (spurious) | corners vs truth px "
      "median / max | corners vs ViSP's px median / max | position mm median / max | rotation "
      "deg median / max | time ms median / p99 | time ÷ anchor (same decimation) |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
}

void print_rows(const ImageCase& c, const std::vector<Pipeline>& pipes,
                const std::vector<Measured>& ms) {
  for (std::size_t i = 0; i < pipes.size(); ++i) {
    const Measured& m = ms[i];
    double anchor_ms = NAN;
    for (std::size_t j = 0; j < pipes.size(); ++j)
      if (pipes[j].anchor && pipes[j].decimation == pipes[i].decimation)
        anchor_ms = median(ms[j].time_ms);
    char found[48], time[48], ratio[16];
    std::snprintf(found, sizeof found, "%d / %d (%d)", m.found, m.expected, m.spurious);
    std::snprintf(time, sizeof time, "%.2f / %.2f", median(m.time_ms), quantile(m.time_ms, 0.99));
    std::snprintf(ratio, sizeof ratio, "%.2f", median(m.time_ms) / anchor_ms);
    std::printf("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", c.set.c_str(),
                c.label.c_str(), pipes[i].name.c_str(), found, fmt2(m.corner_truth_px).c_str(),
                fmt2(m.corner_visp_px).c_str(), fmt2(m.t_mm, "%.2f / %.2f").c_str(),
                fmt2(m.rot_deg, "%.3f / %.3f").c_str(), time, ratio);
  }
  for (std::size_t i = 0; i < pipes.size(); ++i)
    std::printf(
        "[ %s %s ] %s: corners vs %s: mean offset (%+.3f, %+.3f) px, outward median "
        "%+.3f px; distance error median %+.2f %%\n",
        c.set.c_str(), c.label.c_str(), pipes[i].name.c_str(),
        ms[i].corner_truth_px.empty() ? "ViSP's" : "truth", ms[i].mean_offset_px.x(),
        ms[i].mean_offset_px.y(), median(ms[i].outward_px), median(ms[i].range_pct));
  std::fflush(stdout);
}

cv::Mat read_gray(const ImageCase& c) {
  cv::Mat g = cv::imread(c.path.string(), cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(g.empty()) << c.path;
  EXPECT_EQ(g.cols, c.cam.width) << c.path;
  EXPECT_EQ(g.rows, c.cam.height) << c.path;
  return g;
}

// Index of a pipeline by name prefix.
std::size_t idx(const std::vector<Pipeline>& p, const std::string& prefix) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p[i].name.rfind(prefix, 0) == 0) return i;
  ADD_FAILURE() << "no pipeline " << prefix;
  return 0;
}

// The six pipelines the assertions compare, found by name once.
struct PipeIdx {
  std::size_t a2, o2, ob, ol, a1, o1;
};
PipeIdx pipe_idx(const std::vector<Pipeline>& p) {
  return {idx(p, "anchor d2"),        idx(p, "ours d2 (tracker"), idx(p, "ours d2, one-tag"),
          idx(p, "ours d2, linear"), idx(p, "anchor d1"),        idx(p, "ours d1")};
}

// ours with a linear response is libapriltag behind a wrapper: its corners
// must be the anchor's exactly (the wrapper adds nothing and loses nothing).
void expect_wrapper_faithful(const Measured& anchor, const Measured& ours_linear) {
  ASSERT_EQ(anchor.tags.size(), ours_linear.tags.size());
  std::map<int, Corners> a;
  for (const TagResult& r : anchor.tags) a[r.id] = r.corners;
  for (const TagResult& r : ours_linear.tags) {
    ASSERT_TRUE(a.count(r.id)) << "tag " << r.id;
    for (int k = 0; k < 4; ++k)
      EXPECT_LT((r.corners[k] - a[r.id][k]).norm(), 1e-9) << "tag " << r.id;
  }
}

// ---- The sets ----

TEST(RealImageSets, ViSPPhotoTwelveTagsOnOneSheet) {
  const std::optional<ImageCase> c = load_photo();
  if (!c)
    GTEST_SKIP() << kViSP << " (AprilTag.pgm and its ground truth) is absent: install the Debian "
                 << "package visp-images-data";
  ASSERT_EQ(c->tags.size(), 12u);
  for (const TagRef& t : c->tags) ASSERT_TRUE(t.visp && t.T_cam_tag) << "tag " << t.id;
  const cv::Mat gray = read_gray(*c);
  ASSERT_FALSE(gray.empty());
  std::vector<Pipeline> pipes = make_pipelines(c->family);
  const std::vector<Measured> ms = measure(*c, gray, pipes);
  print_header();
  print_rows(*c, pipes, ms);

  // Coplanarity of the twelve recovered poses, and of ViSP's own.
  std::printf(
      "\n| poses | tags | centres off the fitted plane mm RMS / max | tag normal to plane "
      "normal deg median / max |\n|---|---|---|---|\n");
  std::vector<Planarity> plan(pipes.size());
  auto row = [](const std::string& name, const std::vector<Eigen::Isometry3d>& T) {
    const Planarity p = planarity(T);
    std::printf("| %s | %zu | %.2f / %.2f | %.2f / %.2f |\n", name.c_str(), T.size(),
                p.centre_rms_mm, p.centre_max_mm, p.normal_median_deg, p.normal_max_deg);
    return p;
  };
  {
    std::vector<Eigen::Isometry3d> T;
    for (const TagRef& t : c->tags) T.push_back(*t.T_cam_tag);
    row("ViSP's reference poses", T);
  }
  for (std::size_t i = 0; i < pipes.size(); ++i) {
    std::vector<Eigen::Isometry3d> T;
    for (const TagResult& r : ms[i].tags)
      if (r.pose_ok) T.push_back(r.T_cam_tag);
    plan[i] = row(pipes[i].name, T);
  }
  std::fflush(stdout);

  const auto [a2, o2, ob, ol, a1, o1] = pipe_idx(pipes);
  // The wrapper with libapriltag's own (linear) response is the anchor exactly.
  expect_wrapper_faithful(ms[a2], ms[ol]);
  // The gate (issue 24): at each decimation ours finds what plain
  // libapriltag finds, with no more false positives.
  for (auto [o, a] : {std::pair{o2, a2}, std::pair{o1, a1}}) {
    SCOPED_TRACE(pipes[o].name);
    EXPECT_GE(ms[o].found, ms[a].found);
    EXPECT_LE(ms[o].spurious, ms[a].spurious);
  }

  // Measured 2026-11-27 (docs/BENCHMARKS.md, issue 16, real image sets):
  // ours (sRGB) against ViSP's corners, which are libapriltag's at
  // decimation 1 in linear response: median 0.16 px, max 0.62 px, the quads
  // 0.13 px larger (sRGB decoding moves edges toward the bright side); the
  // tags' positions 1.5-1.7 mm (0.3 %) nearer than ViSP's, max 3.9 mm;
  // rotations 0.17 deg median. Bounds: about 1.5x those figures, so that a
  // real change fails and load or rounding does not.
  for (std::size_t i : {o2, ob, o1}) {
    SCOPED_TRACE(pipes[i].name);
    const Measured& m = ms[i];
    EXPECT_EQ(m.found, 12);
    EXPECT_EQ(m.spurious, 0);
    ASSERT_EQ(m.t_mm.size(), 12u);
    EXPECT_LT(median(m.corner_visp_px), 0.25);
    EXPECT_LT(maxv(m.corner_visp_px), 1.0);
    EXPECT_LT(median(m.t_mm), 2.5);
    EXPECT_LT(maxv(m.t_mm), 6.0);
    EXPECT_LT(median(m.rot_deg), 0.3);
    EXPECT_LT(maxv(m.rot_deg), 0.6);
    // The sheet: every pipeline and ViSP's own poses leave 1.05-1.35 mm RMS
    // (max 1.9-2.5 mm) of the centres off one plane and tilt the tags
    // 1.7-2.0 deg (max 2.6-2.7) from it - the paper's own unevenness and the
    // single-tag poses' depth noise.
    EXPECT_LT(plan[i].centre_rms_mm, 1.6);
    EXPECT_LT(plan[i].centre_max_mm, 3.0);
    EXPECT_LT(plan[i].normal_median_deg, 2.5);
    EXPECT_LT(plan[i].normal_max_deg, 3.5);
  }
  // The bundle path (IPPE seeds + Levenberg-Marquardt) is not worse than
  // the tag poses it starts from.
  EXPECT_LE(median(ms[ob].t_mm), 1.1 * median(ms[o2].t_mm) + 0.2);
  EXPECT_LE(plan[ob].centre_rms_mm, 1.1 * plan[o2].centre_rms_mm + 0.1);
  // Not worse than the anchor beyond a margin on the one geometric truth,
  // the flat sheet (measured: ours 1.07 / 1.08 mm RMS and 1.76 / 1.75 deg
  // against the anchor's 1.16 / 1.35 mm and 1.98 / 1.83 deg at d2 / d1).
  for (auto [o, a] : {std::pair{o2, a2}, std::pair{o1, a1}}) {
    SCOPED_TRACE(pipes[o].name);
    EXPECT_LE(plan[o].centre_rms_mm, 1.15 * plan[a].centre_rms_mm + 0.1);
    EXPECT_LE(plan[o].normal_median_deg, 1.15 * plan[a].normal_median_deg + 0.1);
  }
}

void run_render_set(const std::string& res) {
  std::vector<ImageCase> cases;
  for (TagFamilyId f : {TagFamilyId::kTag36h11, TagFamilyId::kStandard41h12})
    if (auto c = load_render(res, f)) cases.push_back(*c);
  if (cases.empty())
    GTEST_SKIP() << kViSP / "benchmark" / res << " is absent: install the Debian package "
                 << "visp-images-data";
  std::printf(
      "[ render %s ] skipped families (not in TagFamilyId): tag16h5, tagCircle21h7, "
      "tag25h9, tagCustom48h12, tagCircle49h12, tagStandard52h13\n",
      res.c_str());
  print_header();
  for (const ImageCase& c : cases) {
    SCOPED_TRACE(c.label);
    const cv::Mat gray = read_gray(c);
    ASSERT_FALSE(gray.empty());
    std::vector<Pipeline> pipes = make_pipelines(c.family);
    const std::vector<Measured> ms = measure(c, gray, pipes);
    print_rows(c, pipes, ms);
    const auto [a2, o2, ob, ol, a1, o1] = pipe_idx(pipes);
    // These renders' edges are symmetric in the stored grey levels: the
    // linear response is the right one for them, and with it ours is the
    // anchor exactly.
    expect_wrapper_faithful(ms[a2], ms[ol]);
    // The gate (issue 24): at each decimation ours finds what plain
    // libapriltag finds, with no more false positives.
    for (auto [o, a] : {std::pair{o2, a2}, std::pair{o1, a1}}) {
      SCOPED_TRACE(pipes[o].name);
      EXPECT_GE(ms[o].found, ms[a].found);
      EXPECT_LE(ms[o].spurious, ms[a].spurious);
    }

    // The tracker's default (sRGB) decodes a ramp that was never encoded:
    // every edge moves toward the bright side, by 0.32-0.69 px here (the
    // tags are texture-filtered and antialiased over several pixels). The
    // tag36h11 border square is dark inside a light ring, so its quad grows
    // and the tags come out 0.5-2.4 % nearer; tagStandard41h12's border
    // square is light inside a dark ring, so its quad shrinks and the tags
    // come out 0.8-1.3 % farther. Measured (docs/BENCHMARKS.md, issue 16,
    // real image sets): corners vs truth 0.42-0.73 px median, max 1.64 px,
    // anchor 0.18-0.41 px; rotations 0.03-0.22 deg median, no worse than the
    // anchor's. These checks pin that behaviour (a fix of the response
    // handling must show up here) with ~1.3x headroom.
    for (std::size_t i : {o2, ob, o1}) {
      SCOPED_TRACE(pipes[i].name);
      const Measured& m = ms[i];
      EXPECT_EQ(m.found, 5);
      EXPECT_EQ(m.spurious, 0);
      ASSERT_EQ(m.t_mm.size(), 5u);
      EXPECT_LT(median(m.corner_truth_px), 1.0);
      EXPECT_LT(maxv(m.corner_truth_px), 2.2);
      EXPECT_LT(std::abs(median(m.range_pct)), 3.2);
      // Issue 24 (detection on the image as delivered, the sRGB refit after):
      // 0.42-0.44 deg median on the 640x480 tagStandard41h12 render (the
      // render is linear: sRGB is the wrong response for it), else <= 0.25.
      EXPECT_LT(median(m.rot_deg), 0.55);
      if (c.family == TagFamilyId::kTag36h11)
        EXPECT_GT(median(m.outward_px), 0.25) << "sRGB decoding no longer grows the dark square";
      else
        EXPECT_LT(median(m.outward_px), -0.2) << "sRGB decoding no longer shrinks the light square";
    }
    EXPECT_LE(median(ms[ob].t_mm), 1.1 * median(ms[o2].t_mm) + 0.5);
    // Against the anchor: the margin is that edge shift (at most 0.5 px more
    // corner error, 2.5 % more distance error) and no worse rotation.
    for (auto [o, a] : {std::pair{o2, a2}, std::pair{o1, a1}}) {
      SCOPED_TRACE(pipes[o].name);
      EXPECT_LE(median(ms[o].corner_truth_px), median(ms[a].corner_truth_px) + 0.5);
      EXPECT_LE(std::abs(median(ms[o].range_pct)), std::abs(median(ms[a].range_pct)) + 2.5);
      // The wrong (sRGB) response on these linear renders: up to 1.5x the
      // anchor's median rotation error (0.42 / 0.44 against 0.34 / 0.30 deg
      // at d2 / d1, 640x480 tagStandard41h12; issue 24); with the right one
      // (linear) ours is the anchor exactly (expect_wrapper_faithful above).
      EXPECT_LE(median(ms[o].rot_deg), 1.6 * median(ms[a].rot_deg) + 0.02);
    }
  }
}

TEST(RealImageSets, ViSPRenderedBenchmark640x480) { run_render_set("640x480"); }
TEST(RealImageSets, ViSPRenderedBenchmark1920x1080) { run_render_set("1920x1080"); }


// ---- The Swarmathon photographs (issue 24): real sRGB JPEGs, 47 tags ----
//
// tests/data/apriltag_photos (README.md there: NASA Kennedy, CC BY-SA 2.0,
// taken from the AprilTag repository's test/data with its reference
// corners). Every tag is tag36h11 id 0, so detections are matched to the
// reference by position (centre within half the reference's side); a
// detection matching no reference is a false positive. No intrinsics:
// recall, false positives, corners and time only.

const fs::path kSwarm = fs::path(DENTAR_SOURCE_DIR) / "tests/data/apriltag_photos";

struct PhotoRef {
  std::string name;
  cv::Mat gray;
  std::vector<Corners> refs;  // OpenCV px
};

std::vector<PhotoRef> load_swarmathon() {
  std::vector<PhotoRef> out;
  for (const char* stem :
       {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c", "34139872896_defdb2f8d9_c"}) {
    PhotoRef p;
    p.name = stem;
    p.gray = cv::imread((kSwarm / (std::string(stem) + ".jpg")).string(), cv::IMREAD_GRAYSCALE);
    if (p.gray.empty()) continue;
    const auto refs = test::read_swarm_refs(kSwarm / (std::string(stem) + ".txt"));
    if (refs.empty()) continue;
    for (const auto& r : refs) p.refs.push_back(r.corners);
    out.push_back(std::move(p));
  }
  return out;
}

struct PhotoScore {
  int found = 0, expected = 0, spurious = 0;
  std::vector<double> corner_px;
  std::vector<double> time_ms;
};

Eigen::Vector2d centre_of(const Corners& c) { return (c[0] + c[1] + c[2] + c[3]) / 4; }

void score_photo(const PhotoRef& p, const std::vector<TagResult>& det, PhotoScore& s) {
  s.expected += static_cast<int>(p.refs.size());
  std::vector<bool> used(det.size(), false);
  for (const Corners& r : p.refs) {
    const double side = (r[1] - r[0]).norm();
    int best = -1;
    double best_d = 0.5 * side;
    for (std::size_t i = 0; i < det.size(); ++i) {
      const double d = (centre_of(det[i].corners) - centre_of(r)).norm();
      if (!used[i] && d < best_d) {
        best_d = d;
        best = static_cast<int>(i);
      }
    }
    if (best < 0) continue;
    used[static_cast<std::size_t>(best)] = true;
    ++s.found;
    for (int k = 0; k < 4; ++k) s.corner_px.push_back((det[static_cast<std::size_t>(best)].corners[k] - r[k]).norm());
  }
  for (bool u : used) s.spurious += u ? 0 : 1;
}

TEST(RealImageSets, SwarmathonPhotosOursFindsWhatLibapriltagFinds) {
  const std::vector<PhotoRef> photos = load_swarmathon();
  if (photos.size() != 3)
    GTEST_SKIP() << kSwarm << " (three JPEGs and their reference corners) is absent or incomplete";
  ImageCase none;  // no intrinsics, no per-id references: no poses
  none.cam = pinhole(photos[0].gray.cols, photos[0].gray.rows, 600, 600, 400, 266);
  std::vector<Pipeline> pipes;
  {
    auto add_anchor = [&](const std::string& name, float dec) {
      auto a = std::make_shared<PlainAnchor>(TagFamilyId::kTag36h11, dec);
      pipes.push_back({name, true, a->decimation(),
                       [a](const cv::Mat& g, const ImageCase& c) { return a->run(g, c); }});
    };
    auto add_ours = [&](const std::string& name, double dec, CameraResponse resp) {
      auto o = std::make_shared<Ours>(TagFamilyId::kTag36h11, dec, resp, PoseMode::kTagPoses);
      if (!o->ok()) return;
      pipes.push_back(
          {name, false, dec, [o](const cv::Mat& g, const ImageCase& c) { return o->run(g, c); }});
    };
    add_anchor("anchor d2 (libapriltag defaults)", 0);
    add_ours("ours d2 (tracker default: sRGB refit)", 2, CameraResponse::kSrgb);
    add_ours("ours d2, linear response", 2, CameraResponse::kLinear);
    add_anchor("anchor d1", 1);
    add_ours("ours d1 (sRGB refit)", 1, CameraResponse::kSrgb);
  }
  std::vector<std::vector<PhotoScore>> per(photos.size(), std::vector<PhotoScore>(pipes.size()));
  std::vector<PhotoScore> all(pipes.size());
  constexpr int kReps = 10;
  for (std::size_t ph = 0; ph < photos.size(); ++ph) {
    for (std::size_t i = 0; i < pipes.size(); ++i) {
      score_photo(photos[ph], pipes[i].run(photos[ph].gray, none), per[ph][i]);
      score_photo(photos[ph], pipes[i].run(photos[ph].gray, none), all[i]);
    }
    for (int rep = 0; rep < kReps; ++rep)
      for (std::size_t k = 0; k < pipes.size(); ++k) {
        const std::size_t i = (k + static_cast<std::size_t>(rep)) % pipes.size();
        const auto t0 = std::chrono::steady_clock::now();
        pipes[i].run(photos[ph].gray, none);
        const double ms = std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - t0).count();
        per[ph][i].time_ms.push_back(ms);
        all[i].time_ms.push_back(ms);
      }
  }
  std::printf(
      "\n| photo | pipeline | tags found / reference (false positives) | corners vs reference px "
      "median / max | time ms median | time ÷ anchor (same decimation) |\n|---|---|---|---|---|---|\n");
  auto row = [&](const std::string& photo, const std::vector<PhotoScore>& sc) {
    for (std::size_t i = 0; i < pipes.size(); ++i) {
      double anchor_ms = NAN;
      for (std::size_t j = 0; j < pipes.size(); ++j)
        if (pipes[j].anchor && pipes[j].decimation == pipes[i].decimation)
          anchor_ms = median(sc[j].time_ms);
      std::printf("| %s | %s | %d / %d (%d) | %s | %.2f | %.2f |\n", photo.c_str(),
                  pipes[i].name.c_str(), sc[i].found, sc[i].expected, sc[i].spurious,
                  fmt2(sc[i].corner_px).c_str(), median(sc[i].time_ms),
                  median(sc[i].time_ms) / anchor_ms);
    }
  };
  for (std::size_t ph = 0; ph < photos.size(); ++ph) row(photos[ph].name, per[ph]);
  row("all three", all);
  std::fflush(stdout);

  // The gate: at each decimation, ours (the tracker's default detector)
  // finds every tag the anchor finds on every photo, with no more false
  // positives, and its corners agree with the reference (libapriltag's own
  // detection at decimation 1, on the encoded image: not truth) as well as
  // the anchor's do within 0.25 px in the median. The sRGB refit moves edges
  // by design (libapriltag's gradient peak on encoded grey levels sits
  // toward the bright side): measured 2026-11-27 +0.17 px at d2 (0.515
  // against 0.346), +0.09 px at d1 (0.413 against 0.324).
  for (auto [o, a] : {std::pair{1u, 0u}, std::pair{4u, 3u}}) {
    SCOPED_TRACE(pipes[o].name);
    for (std::size_t ph = 0; ph < photos.size(); ++ph) {
      SCOPED_TRACE(photos[ph].name);
      EXPECT_GE(per[ph][o].found, per[ph][a].found);
      EXPECT_LE(per[ph][o].spurious, per[ph][a].spurious);
    }
    EXPECT_LE(median(all[o].corner_px), median(all[a].corner_px) + 0.25);
  }
  // With the linear response ours is libapriltag behind a wrapper.
  EXPECT_EQ(all[2].found, all[0].found);
  EXPECT_EQ(all[2].spurious, all[0].spurious);
  // The anchor's own recall on these photos (measured 2026-11-27, issue 24:
  // 46 of 47 at decimation 1, the reference's own setting; 34 at 2): the
  // set is read right.
  EXPECT_GE(all[3].found, 44);
  EXPECT_GE(all[0].found, 30);
}

// The tracker keeps 7 corner candidates per outline in libapriltag's quad
// fit instead of its 10 (TagDetectorOptions::corner_candidates, issue 24
// session 13: about 4 % less detection work). On every real photograph the
// project has, at decimation 1 and 2, that finds the same tags with the
// same corners (the refit included) as 10. 6 candidates lose a real tag
// at decimation 1 (34139872896: 9 of 10), so this test can fail.
TEST(RealImageSets, SevenCornerCandidatesFindTheSameTagsAndCorners) {
  std::vector<std::pair<std::string, cv::Mat>> images;
  for (const PhotoRef& p : load_swarmathon()) images.emplace_back(p.name, p.gray);
  const cv::Mat visp = cv::imread((kViSP / "AprilTag.pgm").string(), cv::IMREAD_GRAYSCALE);
  if (!visp.empty()) images.emplace_back("ViSP AprilTag.pgm", visp);
  if (images.empty()) GTEST_SKIP() << kSwarm << " and " << kViSP << " are absent";
  ASSERT_EQ(TrackerOptions{}.detector.corner_candidates, 7);
  int compared = 0;
  for (double dec : {1.0, 2.0}) {
    auto make = [&](int candidates) {
      TagDetectorOptions o = TrackerOptions{}.detector;
      o.families = {TagFamilyId::kTag36h11};
      o.decimation = dec;
      o.response = CameraResponse::kSrgb;
      o.corner_candidates = candidates;
      return TagDetector::create(o);
    };
    auto seven = make(7), ten = make(10);
    ASSERT_TRUE(seven.ok()) << seven.error();
    ASSERT_TRUE(ten.ok()) << ten.error();
    for (const auto& [name, gray] : images) {
      SCOPED_TRACE(name + " decimation " + std::to_string(dec));
      auto a = seven->detect(gray), b = ten->detect(gray);
      ASSERT_TRUE(a.ok() && b.ok());
      ASSERT_EQ(a->size(), b->size());
      // Same ids; match by position (the Swarmathon tags are all id 0).
      for (const DetectedTag& t : *b) {
        double best = 1e9;
        for (const DetectedTag& u : *a)
          if (u.id == t.id) {
            double d = 0;
            for (int k = 0; k < 4; ++k) d = std::max(d, (u.corners_px[k] - t.corners_px[k]).norm());
            best = std::min(best, d);
          }
        EXPECT_LT(best, 1e-6) << "tag id " << t.id;
        ++compared;
      }
    }
  }
  // 58 tags at decimation 1 and 46 at 2 when every image is present.
  EXPECT_GE(compared, 1);
}

}  // namespace
}  // namespace dentar::ar
