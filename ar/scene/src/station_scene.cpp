#include "dentar/ar/station_scene.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "dentar/calibration/camera_file.h"
#include "dentar/haptics/scripts.h"

namespace dentar::ar {
namespace {

using nlohmann::json;
using ojson = nlohmann::ordered_json;  // writer: keys in reading order
constexpr double kDeg = M_PI / 180.0;

// ---- default geometry ---------------------------------------------------------

// Point and outward normal of the head ellipsoid in direction (azimuth about
// +y from +z toward +x, elevation from the x/z plane).
void head_point(const MannequinParams& m, double az_deg, double el_deg, Eigen::Vector3d& p,
                Eigen::Vector3d& n) {
  const double az = az_deg * kDeg, el = el_deg * kDeg;
  const Eigen::Vector3d d(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
  p = m.head_centre_m + m.head_radii_m.cwiseProduct(d);
  n = (p - m.head_centre_m).cwiseQuotient(m.head_radii_m.cwiseProduct(m.head_radii_m)).normalized();
}

// A tag lying on the head: tangent plate 0.5 mm above the surface (a tangent
// plane clears a convex surface), image "down" toward the chin.
TagPlacement head_tag(const MannequinParams& m, int id, double size_m, double az_deg,
                      double el_deg) {
  Eigen::Vector3d p, n;
  head_point(m, az_deg, el_deg, p, n);
  const Eigen::Vector3d z = -n;  // into the tag
  Eigen::Vector3d y = -Eigen::Vector3d::UnitY();
  y = (y - y.dot(z) * z).normalized();
  const Eigen::Vector3d x = y.cross(z);
  TagPlacement t;
  t.id = id;
  t.size_m = size_m;
  t.T_parent_tag.linear().col(0) = x;
  t.T_parent_tag.linear().col(1) = y;
  t.T_parent_tag.linear().col(2) = z;
  t.T_parent_tag.translation() = p + 0.5e-3 * n;
  return t;
}

// ---- JSON helpers ---------------------------------------------------------------

struct ParseError {
  std::string path, message;
};

void check_keys(const json& j, const std::string& path, std::initializer_list<const char*> keys) {
  if (!j.is_object()) throw ParseError{path.empty() ? "(top level)" : path, "must be an object"};
  const std::set<std::string> allowed(keys.begin(), keys.end());
  for (const auto& [k, v] : j.items())
    if (!allowed.count(k))
      throw ParseError{path.empty() ? k : path + "." + k, "unknown key (misspelt?)"};
}

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

const json& req(const json& j, const std::string& path, const char* key) {
  auto it = j.find(key);
  if (it == j.end()) throw ParseError{join(path, key), "missing"};
  return *it;
}

double number(const json& j, const std::string& path, double lo, double hi) {
  if (!j.is_number()) throw ParseError{path, "must be a number"};
  const double v = j.get<double>();
  if (!(std::isfinite(v) && v >= lo && v <= hi)) {
    std::ostringstream os;
    os << "= " << v << " must be in [" << lo << ", " << hi << "]";
    throw ParseError{path, os.str()};
  }
  return v;
}

int integer(const json& j, const std::string& path, int lo, int hi) {
  if (!j.is_number_integer()) throw ParseError{path, "must be an integer"};
  const auto v = j.get<long long>();
  if (v < lo || v > hi)
    throw ParseError{path, "= " + std::to_string(v) + " must be in [" + std::to_string(lo) + ", " +
                               std::to_string(hi) + "]"};
  return static_cast<int>(v);
}

template <int N>
Eigen::Matrix<double, N, 1> vec(const json& j, const std::string& path, double lo, double hi) {
  if (!j.is_array() || j.size() != N)
    throw ParseError{path, "must be an array of " + std::to_string(N) + " numbers"};
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i)
    v[i] = number(j[static_cast<std::size_t>(i)], path + "[" + std::to_string(i) + "]", lo, hi);
  return v;
}

// Pose: {"translation_mm": [x, y, z], "rvec_deg": [rx, ry, rz]} (axis-angle,
// the vector's length is the angle, as OpenCV's rvec but in degrees).
Eigen::Isometry3d pose(const json& j, const std::string& path) {
  check_keys(j, path, {"translation_mm", "rvec_deg"});
  const Eigen::Vector3d t =
      vec<3>(req(j, path, "translation_mm"), path + ".translation_mm", -10000.0, 10000.0);
  const Eigen::Vector3d r = vec<3>(req(j, path, "rvec_deg"), path + ".rvec_deg", -720.0, 720.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double a = r.norm();
  if (a > 0) T.linear() = Eigen::AngleAxisd(a * kDeg, r / a).toRotationMatrix();
  T.translation() = t * 1e-3;
  return T;
}

ojson pose_json(const Eigen::Isometry3d& T) {
  const Eigen::AngleAxisd aa(T.linear());
  const Eigen::Vector3d r = aa.axis() * (aa.angle() / kDeg);
  const Eigen::Vector3d t = T.translation() * 1e3;
  return {{"translation_mm", {t.x(), t.y(), t.z()}}, {"rvec_deg", {r.x(), r.y(), r.z()}}};
}

ojson v3(const Eigen::Vector3d& v, double scale = 1.0) {
  return {v.x() * scale, v.y() * scale, v.z() * scale};
}

std::vector<TagPlacement> tags(const json& j, const std::string& path, const char* pose_key) {
  if (!j.is_array() || j.empty() || j.size() > 64)
    throw ParseError{path, "must be an array of 1..64 tags"};
  std::vector<TagPlacement> out;
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string p = path + "[" + std::to_string(i) + "]";
    check_keys(j[i], p, {"id", "size_mm", pose_key});
    TagPlacement t;
    t.id = integer(req(j[i], p, "id"), p + ".id", 0, 1 << 20);
    t.size_m = number(req(j[i], p, "size_mm"), p + ".size_mm", 1.0, 500.0) * 1e-3;
    t.T_parent_tag = pose(req(j[i], p, pose_key), p + "." + pose_key);
    out.push_back(t);
  }
  return out;
}

ojson tags_json(const std::vector<TagPlacement>& ts, const char* pose_key) {
  ojson a = ojson::array();
  for (const auto& t : ts)
    a.push_back(
        ojson{{"id", t.id}, {"size_mm", t.size_m * 1e3}, {pose_key, pose_json(t.T_parent_tag)}});
  return a;
}

// dump(2) puts every array element on its own line; arrays of plain numbers
// read better on one line ("[1.0, 2.0, 3.0]").
std::string compact_number_arrays(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '[') {
      const std::size_t end = text.find(']', i);
      const std::size_t nested = text.find_first_of("[{\"", i + 1);
      if (end != std::string::npos && (nested == std::string::npos || nested > end)) {
        std::string inner;
        bool space = false;
        for (std::size_t k = i + 1; k < end; ++k) {
          const char ch = text[k];
          if (ch == ' ' || ch == '\n') {
            space = true;
            continue;
          }
          if (space && !inner.empty() && inner.back() == ',') inner += ' ';
          space = false;
          inner += ch;
        }
        out += "[" + inner + "]";
        i = end;
        continue;
      }
    }
    out += text[i];
  }
  return out;
}

int family_codes(TagFamilyId f) { return f == TagFamilyId::kStandard41h12 ? 2115 : 587; }

}  // namespace

const char* tag_family_name(TagFamilyId f) {
  return f == TagFamilyId::kStandard41h12 ? "tagStandard41h12" : "tag36h11";
}

std::optional<TagFamilyId> parse_tag_family(std::string_view name) {
  if (name == "tagStandard41h12") return TagFamilyId::kStandard41h12;
  if (name == "tag36h11") return TagFamilyId::kTag36h11;
  return std::nullopt;
}

Eigen::Vector3d TagPlacement::corner(int k) const {
  static constexpr double kSign[4][2] = {{-1, 1}, {1, 1}, {1, -1}, {-1, -1}};
  const double h = 0.5 * size_m;
  return T_parent_tag * Eigen::Vector3d(kSign[k & 3][0] * h, kSign[k & 3][1] * h, 0.0);
}

std::string MannequinParams::validate() const {
  if (!head_centre_m.allFinite() || head_centre_m.norm() > 1.0)
    return "mannequin.head_centre must be finite and within 1 m of the origin";
  for (int i = 0; i < 3; ++i)
    if (!(head_radii_m[i] >= 0.03 && head_radii_m[i] <= 0.3))
      return "mannequin.head_radii must be in [30, 300] mm";
  if (!(mouth_half_width_m >= 0.01 && mouth_half_width_m < head_radii_m.x()))
    return "mannequin.mouth half width must be in [10 mm, head radius x)";
  if (!(mouth_half_height_m >= 0.005 && mouth_half_height_m < head_radii_m.y()))
    return "mannequin.mouth half height must be in [5 mm, head radius y)";
  if (!(lip_radius_m >= 0.001 && lip_radius_m <= 0.5 * mouth_half_height_m))
    return "mannequin.lip_radius must be in [1 mm, mouth half height / 2]";
  for (const auto* c : {&skin_rgb, &lip_rgb, &gum_rgb, &teeth_rgb})
    if (!(c->minCoeff() >= 0 && c->maxCoeff() <= 1)) return "mannequin colours must be in [0, 1]";
  return {};
}

std::string MirrorSceneParams::validate() const {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!in(thickness_m, 1e-4, 0.01)) return "mirror.thickness must be in [0.1, 10] mm";
  if (!in(neck_length_m, 1e-3, 0.1)) return "mirror.neck_length must be in [1, 100] mm";
  if (!in(neck_radius_m, 2e-4, 0.01)) return "mirror.neck_radius must be in [0.2, 10] mm";
  if (!in(handle_length_m, 0.01, 0.3)) return "mirror.handle_length must be in [10, 300] mm";
  if (!in(handle_radius_m, 5e-4, 0.02)) return "mirror.handle_radius must be in [0.5, 20] mm";
  if (!in(std::abs(stem_tilt_rad), 0.0, M_PI / 2))
    return "mirror.stem_tilt must be in [-90, 90] deg";
  if (!in(paddle_width_m, 0.005, 0.1) || !in(paddle_height_m, 0.005, 0.1))
    return "mirror.paddle size must be in [5, 100] mm";
  if (!in(paddle_thickness_m, 2e-4, 0.02)) return "mirror.paddle_thickness must be in [0.2, 20] mm";
  if (!in(paddle_roof_rad, 0.0, 60 * M_PI / 180)) return "mirror.paddle_roof must be in [0, 60] deg";
  // The eaves (z = height/4 tan(roof)) must lie in front of the back face.
  if (paddle_roof_rad > 0 && 0.25 * paddle_height_m * std::tan(paddle_roof_rad) >= paddle_thickness_m)
    return "mirror.paddle_thickness must exceed the roof's eave depth (paddle height / 4 x tan(roof)); "
           "make the paddle thicker or the roof flatter";
  return {};
}

std::string CalibrationFixtures::validate() const {
  for (std::size_t i = 0; i < divots_man.size(); ++i)
    if (!divots_man[i].allFinite() || divots_man[i].norm() > 1.0)
      return "calibration_fixtures.divots_mm[" + std::to_string(i) + "] must be finite, within 1 m";
  for (std::size_t i = 0; i < landmarks_tooth.size(); ++i)
    if (!landmarks_tooth[i].allFinite() || landmarks_tooth[i].norm() > 0.1)
      return "calibration_fixtures.tooth_landmarks_mm[" + std::to_string(i) +
             "] must be finite, within 100 mm";
  return {};
}

void StationScene::set_step_report(const CalibrationStepReport& r) {
  static const char* const kOrder[] = {"camera", "hand_eye", "pivot", "register", "tooth", "mirror", "check"};
  auto rank = [](const std::string& step) {
    for (int i = 0; i < 7; ++i)
      if (step == kOrder[i]) return i;
    return 7;
  };
  for (auto& e : calibration_report)
    if (e.step == r.step) {
      e = r;
      return;
    }
  auto it = calibration_report.begin();
  while (it != calibration_report.end() && rank(it->step) <= rank(r.step)) ++it;
  calibration_report.insert(it, r);
}

const CalibrationStepReport* StationScene::step_report(const std::string& step) const {
  for (const auto& e : calibration_report)
    if (e.step == step) return &e;
  return nullptr;
}

std::string StationPolicy::validate() const {
  std::ostringstream os;
  if (!(check_threshold_m > 0 && check_threshold_m <= 10e-3))
    os << "station_policy.check_threshold_mm = " << check_threshold_m * 1e3 << " must be in (0, 10]";
  else if (!(max_age_days > 0 && max_age_days <= 3650))
    os << "station_policy.max_age_days = " << max_age_days << " must be in (0, 3650]";
  else if (!(tag_moved_m > 0 && tag_moved_m <= 50e-3))
    os << "station_policy.tag_moved_mm = " << tag_moved_m * 1e3 << " must be in (0, 50]";
  else if (!(tip_check_m > 0 && tip_check_m <= 10e-3))
    os << "station_policy.tip_check_mm = " << tip_check_m * 1e3 << " must be in (0, 10]";
  else if (health_divot < 0 || health_divot > 63)
    os << "station_policy.health_divot = " << health_divot << " must be in 0..63";
  return os.str();
}

std::string StereoRig::validate(const calibration::CameraIntrinsics& left) const {
  if (!present) return {};
  if (std::string e = camera_right.validate(); !e.empty()) return "stereo.camera_right: " + e;
  if (camera_right.width != left.width || camera_right.height != left.height)
    return "stereo.camera_right is " + std::to_string(camera_right.width) + "x" +
           std::to_string(camera_right.height) + " px but camera (the left eye) is " +
           std::to_string(left.width) + "x" + std::to_string(left.height) +
           " px: both eyes must deliver the same size (the side-by-side frame); calibrate both at one size";
  if (std::string e = calibration::check_rigid(T_caml_camr, "stereo.T_left_right"); !e.empty()) return e;
  const double b = baseline_m();
  if (!(b >= 0.01 && b <= 0.3))
    return "stereo.T_left_right: the baseline is " + std::to_string(b * 1e3) +
           " mm; a head's eyes are 10..300 mm apart (typically 60-65 mm)";
  return {};
}

StereoRig make_stereo_rig(const calibration::CameraIntrinsics& left, double baseline_m,
                          const std::optional<calibration::CameraIntrinsics>& right) {
  StereoRig r;
  r.present = true;
  r.camera_right = right ? *right : left;
  r.T_caml_camr = Eigen::Isometry3d::Identity();
  r.T_caml_camr.translation() = Eigen::Vector3d(baseline_m, 0, 0);
  return r;
}

std::string StationScene::validate() const {
  if (std::string e = stereo.validate(calibration.camera); !e.empty()) return e;
  if (std::string e = mannequin.validate(); !e.empty()) return e;
  if (std::string e = policy.validate(); !e.empty()) return e;
  if (!fixtures.divots_man.empty() && policy.health_divot >= static_cast<int>(fixtures.divots_man.size()))
    return "station_policy.health_divot = " + std::to_string(policy.health_divot) +
           " names no divot (calibration_fixtures.divots_mm has " +
           std::to_string(fixtures.divots_man.size()) + ")";
  if (hand_eye.present) {
    if (std::string e = calibration::check_rigid(hand_eye.T_hand_cam, "hand_eye.T_hand_cam"); !e.empty())
      return e;
    if (hand_eye.T_hand_cam.translation().norm() > 1.0)
      return "hand_eye.T_hand_cam: the camera is over 1 m from the body that carries it";
  }
  if (std::string e = fixtures.validate(); !e.empty()) return e;
  if (std::string e = mirror.validate(); !e.empty()) return e;
  if (std::string e = calibration.validate(); !e.empty()) return "calibration: " + e;
  if (!(tooth_voxel_m >= 0.02e-3 && tooth_voxel_m <= 0.5e-3))
    return "tooth.voxel must be in [0.02, 0.5] mm";
  std::set<int> ids;
  const int n = family_codes(family);
  if (std::string e = pen.validate(); !e.empty()) return e;
  for (const auto* list : {&mannequin_tags, &mirror_tags, &pen.tags}) {
    const char* what = list == &mannequin_tags ? "mannequin_tags" : list == &mirror_tags ? "mirror_tags" : "pen.tags";
    for (std::size_t i = 0; i < list->size(); ++i) {
      const TagPlacement& t = (*list)[i];
      const std::string f = std::string(what) + "[" + std::to_string(i) + "]";
      if (t.id < 0 || t.id >= n)
        return f + ".id = " + std::to_string(t.id) + " is not a " + tag_family_name(family) +
               " code (0.." + std::to_string(n - 1) + ")";
      if (!ids.insert(t.id).second)
        return f + ".id = " + std::to_string(t.id) + " is used twice (ids must be unique)";
      if (!(t.size_m >= 1e-3 && t.size_m <= 0.5)) return f + ".size must be in [1, 500] mm";
      if (std::string e = calibration::check_rigid(t.T_parent_tag, f + ".pose"); !e.empty())
        return e;
    }
  }
  if (mannequin_tags.empty()) return "mannequin_tags must hold at least one tag";
  if (mirror_tags.empty()) return "mirror_tags must hold at least one tag";
  return {};
}

const TagPlacement* StationScene::find_tag(int id) const {
  for (const auto* list : {&mannequin_tags, &mirror_tags, &pen.tags})
    for (const auto& t : *list)
      if (t.id == id) return &t;
  return nullptr;
}

std::string PenParams::validate() const {
  if (tags.empty()) return {};  // no pen at this station
  if (tags.size() > 4) return "pen.tags must hold at most 4 tags";
  if (!(flag_size_m >= 5e-3 && flag_size_m <= 0.2)) return "pen.flag_size must be in [5, 200] mm";
  if (std::string e = calibration::check_rigid(T_ptag_tip, "pen.T_ptag_tip"); !e.empty()) return e;
  if (T_ptag_tip.translation().norm() > 0.5) return "pen.T_ptag_tip: the tip is more than 500 mm from the flag";
  return {};
}

PenParams default_pen() {
  PenParams p;
  TagPlacement front;
  front.id = 30;
  front.size_m = 0.025;
  TagPlacement back = front;
  back.id = 31;
  // Printed on the back of the same flag: turned about y, 0.1 mm behind (paper).
  back.T_parent_tag.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  back.T_parent_tag.translation() = Eigen::Vector3d(0, 0, 8e-3);  // folded around an 8 mm pen
  p.tags = {front, back};
  p.flag_size_m = 0.055;
  // Tip frame: z along +y of the flag (down the pen), x along the flag's x.
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d::UnitX();
  R.col(2) = Eigen::Vector3d::UnitY();
  R.col(1) = R.col(2).cross(R.col(0));
  p.T_ptag_tip.linear() = R;
  p.T_ptag_tip.translation() = Eigen::Vector3d(0, 0.130, 4e-3);
  return p;
}

StationScene box_station_scene() {
  StationScene s = default_station_scene();
  s.name = "box: a flat board of 6 tags (try-out with a webcam)";
  s.mannequin_tags.clear();
  Eigen::Matrix3d R;  // tag x = man x, tag y = -man y, tag z (into the tag) = -man z
  R << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  int id = 0;
  for (double y : {0.055, -0.055})
    for (double x : {-0.06, 0.0, 0.06}) {
      TagPlacement t;
      t.id = id++;
      t.size_m = 0.025;
      t.T_parent_tag.linear() = R;
      t.T_parent_tag.translation() = Eigen::Vector3d(x, y, 0);
      s.mannequin_tags.push_back(t);
    }
  Eigen::Isometry3d T_tooth_dev = s.calibration.T_man_tooth.inverse() * s.calibration.T_man_dev;
  s.calibration.T_man_tooth = Eigen::Isometry3d::Identity();
  s.calibration.T_man_tooth.translation() = Eigen::Vector3d(0, 0, 0.014);
  // The device (or the pen's) workspace over the board: its centre 60 mm above the board's
  // centre, so the default workspace box (haptics::DeviceLimits, +-60 mm along dev y = up) sits
  // on the board and the crown (14-21 mm above it) is within every common profile's reach.
  T_tooth_dev.translation() = Eigen::Vector3d(0, 0, kBoxWorkspaceAboveBoard_m - 0.014);
  s.calibration.T_man_dev = s.calibration.T_man_tooth * T_tooth_dev;
  s.fixtures.divots_man.clear();
  return s;
}

std::optional<StationScene> builtin_station_scene(std::string_view name) {
  if (name == "default") return default_station_scene();
  if (name == "box") return box_station_scene();
  return std::nullopt;
}

CalibrationFixtures default_calibration_fixtures() {
  CalibrationFixtures f;
  // Divots on the face around the mouth, between the tags: cheeks, upper cheeks, jaw, chin and
  // forehead, so they surround the tooth site in 3-D (the face's curvature gives depth).
  const MannequinParams m;
  const double spots[8][2] = {{-32, 0}, {32, 0}, {-30, 15}, {30, 15},
                              {-58, -25}, {58, -25}, {0, -35}, {0, 35}};
  for (const auto& sp : spots) {
    Eigen::Vector3d p, n;
    head_point(m, sp[0], sp[1], p, n);
    f.divots_man.push_back(p);
  }
  // Molar landmarks in the tooth frame (origin at the crown centre on the cervical plane, +z
  // occlusal): four cusp tips 6.6 mm up, the buccal (-y) and lingual (+y) cervical points.
  for (const auto& q : {Eigen::Vector3d(-2.5, -2.8, 6.6), Eigen::Vector3d(2.5, -2.8, 6.6),
                        Eigen::Vector3d(2.5, 2.8, 6.6), Eigen::Vector3d(-2.5, 2.8, 6.6),
                        Eigen::Vector3d(0, -5.3, 0.3), Eigen::Vector3d(0, 5.3, 0.3)})
    f.landmarks_tooth.push_back(q * 1e-3);
  return f;
}

calibration::CameraIntrinsics default_camera(int width_px, int height_px) {
  calibration::CameraIntrinsics k;
  k.width = width_px;
  k.height = height_px;
  // ~56 deg horizontal field of view, as head-mounted pass-through cameras
  // are often cropped to; a slightly off-centre principal point as real
  // calibrations show.
  k.fx = k.fy = 0.9375 * width_px;
  k.cx = 0.5 * (width_px - 1) + 0.004 * width_px;
  k.cy = 0.5 * (height_px - 1) - 0.003 * height_px;
  k.dist = {-0.12, 0.06, 0.0004, -0.0003, 0.0};
  return k;
}

StationScene default_station_scene() {
  StationScene s;
  s.name = "default phantom-head station";
  set_mannequin_layout(s, MannequinLayout::kFront12);

  // Lower-left first molar on the dental arch (synth's arch: x = 25 sin(phi),
  // z = -45 + 35 cos(phi) mm at phi = 56 deg), crown up, mesial toward the
  // front teeth, the cervical line level with the gum ridge.
  const double phi = 56 * kDeg;
  const Eigen::Vector3d site(0.025 * std::sin(phi), -0.016, -0.045 + 0.035 * std::cos(phi));
  const Eigen::Vector3d distal =
      Eigen::Vector3d(0.025 * std::cos(phi), 0.0, -0.035 * std::sin(phi)).normalized();
  Eigen::Isometry3d T_man_tooth = Eigen::Isometry3d::Identity();
  T_man_tooth.linear().col(0) = distal;
  T_man_tooth.linear().col(2) = Eigen::Vector3d::UnitY();
  T_man_tooth.linear().col(1) = Eigen::Vector3d::UnitY().cross(distal);
  T_man_tooth.translation() = site;

  calibration::StationCalibration& c = s.calibration;
  c.camera = default_camera(640, 480);
  // The built-in camera is the footage generator's, which encodes sRGB (generator v2):
  // its response is known, not measured.
  s.camera_provenance.response.kind = "srgb";
  c.T_man_tooth = T_man_tooth;
  const haptics::Station hs = haptics::default_station();
  c.T_man_dev = T_man_tooth * hs.T_tooth_dev;
  c.T_sty_tip = hs.T_sty_tip;
  c.mirror_radius_m = 0.011;
  s.fixtures = default_calibration_fixtures();

  // Mirror: the paddle sits on the handle 85 mm from the disc centre, the
  // front tag facing the same side as the reflecting face. mtag = front tag
  // frame (x along the handle away from the head, z into the tag).
  const MirrorSceneParams& mp = s.mirror;
  const Eigen::Vector3d stem_dir(0, -std::cos(mp.stem_tilt_rad), -std::sin(mp.stem_tilt_rad));
  const Eigen::Vector3d stem_start(0, -0.9 * c.mirror_radius_m, -1.5e-3);
  const Eigen::Vector3d z_mtag =
      -(Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(stem_dir) * stem_dir).normalized();
  Eigen::Isometry3d T_mir_mtag = Eigen::Isometry3d::Identity();
  T_mir_mtag.linear().col(0) = stem_dir;
  T_mir_mtag.linear().col(2) = z_mtag;
  T_mir_mtag.linear().col(1) = z_mtag.cross(stem_dir);
  // Front face of the paddle just clear of the handle's top.
  T_mir_mtag.translation() = stem_start + 0.085 * stem_dir - (mp.handle_radius_m + 0.5e-3) * z_mtag;
  c.T_mtag_mir = T_mir_mtag.inverse();
  set_mirror_paddle(s, MirrorPaddle::kRoof);
  s.pen = default_pen();
  return s;
}

void set_mannequin_layout(StationScene& s, MannequinLayout kind) {
  const MannequinParams& m = s.mannequin;
  // (azimuth, elevation) in degrees on the head ellipsoid (head_point above).
  struct Spot {
    double az, el;
  };
  // The first 12 (ids 0..11, both layouts): two on the upper forehead, four
  // across the brow, four on the cheeks beside the mouth, two on the chin.
  static const Spot kFront[12] = {{-20, 50}, {20, 50},   {-45, 25}, {-15, 25},
                                  {15, 25},  {45, 25},   {-70, 5},  {-45, -12},
                                  {45, -12}, {70, 5},    {-18, -48}, {18, -48}};
  // kWrap20 adds ids 12..19, in left/right pairs: cheekbones, temples, the
  // sides above the ears and the jaw, so that a camera 20-60 deg to a side
  // sees 6-7 tags within 55 deg of face-on (12 tags: 4-5; docs/BENCHMARKS.md,
  // issue 16 head layout). No two printed patterns (25.2 mm) overlap (their
  // quiet zones may, as the forehead pair's always did), and every centre is
  // >= 21 mm from the calibration divots.
  static const Spot kWrap[8] = {{-45, 5},  {45, 5},  {-50, 45}, {50, 45},
                                {-70, 25}, {70, 25}, {-40, -30}, {40, -30}};
  // kFront12Large: the same spots, larger tags on the forehead (16 mm) and
  // brow (18 mm), the face-on camera's tags (docs/BENCHMARKS.md, issue 16
  // larger brow tags): no printed pattern overlaps another and every plate
  // stays >= 4.6 mm clear of the divots (forehead divot: inner brow pair).
  auto size_m = [kind](int i) {
    if (kind != MannequinLayout::kFront12Large) return 0.014;
    return i < 2 ? 0.016 : i < 6 ? 0.018 : 0.014;
  };
  s.mannequin_tags.clear();
  for (int i = 0; i < 12; ++i)
    s.mannequin_tags.push_back(head_tag(m, i, size_m(i), kFront[i].az, kFront[i].el));
  if (kind == MannequinLayout::kWrap20)
    for (int i = 0; i < 8; ++i)
      s.mannequin_tags.push_back(head_tag(m, 12 + i, 0.014, kWrap[i].az, kWrap[i].el));
}

void set_mirror_paddle(StationScene& s, MirrorPaddle kind) {
  MirrorSceneParams& mp = s.mirror;
  TagPlacement front;
  front.id = 20;
  front.size_m = 0.012;
  TagPlacement back = front;
  back.id = 21;
  // Back face: turned about the tag's y axis (still readable from behind).
  back.T_parent_tag.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  if (kind == MirrorPaddle::kFlat) {
    mp.paddle_width_m = 0.03;
    mp.paddle_height_m = 0.03;
    mp.paddle_thickness_m = 7.0e-3;
    mp.paddle_roof_rad = 0;
    back.T_parent_tag.translation() = Eigen::Vector3d(0, 0, mp.paddle_thickness_m);
    s.mirror_tags = {front, back};
    return;
  }
  // Roof: each face carries a 12 mm tag whose printed plate (24 mm with its
  // quiet zone) spans the face's slope from ridge to eave: 40 mm of paddle
  // height at 35 deg; 9 mm deep so the handle (its top 0.5 mm behind z = 0)
  // and the eaves (6.9 mm) both fit in front of the back face.
  mp.paddle_width_m = 0.03;
  mp.paddle_height_m = 0.04;
  mp.paddle_thickness_m = 9.0e-3;
  mp.paddle_roof_rad = 35 * M_PI / 180;
  const double a = mp.paddle_roof_rad, q = 0.25 * mp.paddle_height_m;
  // The -y face: its outward normal (-z of the tag) leans toward -y, so the
  // tag's z axis is +z turned by -a about x; the tag's y axis runs up the
  // slope toward the ridge.
  TagPlacement lo = front, hi = front;
  lo.T_parent_tag.linear() = Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitX()).toRotationMatrix();
  lo.T_parent_tag.translation() = Eigen::Vector3d(0, -q, 0);
  hi.id = 22;
  hi.T_parent_tag.linear() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
  hi.T_parent_tag.translation() = Eigen::Vector3d(0, q, 0);
  back.T_parent_tag.translation() = Eigen::Vector3d(0, 0, mp.paddle_thickness_m);
  s.mirror_tags = {lo, back, hi};
}

std::string station_scene_to_json(const StationScene& s) {
  const auto& m = s.mannequin;
  const auto& c = s.calibration;
  const auto& k = c.camera;
  ojson j;
  j["format"] = "dentar-station";
  j["version"] = kStationFileVersion;
  j["name"] = s.name;
  const CameraProvenance& cp = s.camera_provenance;
  if (!cp.file.empty()) {
    j["camera"] = {{"file", cp.file}};
  } else {
    j["camera"] = {{"width", k.width}, {"height", k.height}, {"fx", k.fx},    {"fy", k.fy},
                   {"cx", k.cx},       {"cy", k.cy},         {"dist", k.dist}};
    if (!cp.model.empty()) j["camera"]["model"] = cp.model;
    if (cp.rms_px >= 0) j["camera"]["rms_px"] = cp.rms_px;
    if (!cp.std_devs.empty()) j["camera"]["std_devs"] = cp.std_devs;
    if (!cp.date.empty()) j["camera"]["date"] = cp.date;
    if (!cp.device.empty()) j["camera"]["device"] = cp.device;
  }
  if (!cp.device_id.empty()) j["camera"]["device_id"] = cp.device_id;
  if (cp.latency_ms >= 0) j["camera"]["latency_ms"] = cp.latency_ms;
  if (!cp.response.kind.empty()) {
    const calibration::CameraResponseCurve& r = cp.response;
    ojson rj;
    rj["kind"] = r.kind;
    if (r.kind == "curve") rj["curve"] = r.table;
    if (r.gamma > 0) rj["gamma"] = r.gamma;
    if (r.gamma_sigma >= 0) rj["gamma_sigma"] = r.gamma_sigma;
    if (r.views > 0) rj["views"] = r.views;
    if (r.edges > 0) rj["edges"] = r.edges;
    j["camera"]["response"] = rj;
  }
  j["tag_family"] = tag_family_name(s.family);
  j["mannequin"] = {
      {"head_centre_mm", v3(m.head_centre_m, 1e3)},
      {"head_radii_mm", v3(m.head_radii_m, 1e3)},
      {"mouth_half_size_mm", {m.mouth_half_width_m * 1e3, m.mouth_half_height_m * 1e3}},
      {"lip_radius_mm", m.lip_radius_m * 1e3},
      {"skin_rgb", v3(m.skin_rgb)},
      {"lip_rgb", v3(m.lip_rgb)},
      {"gum_rgb", v3(m.gum_rgb)},
      {"teeth_rgb", v3(m.teeth_rgb)},
      {"tags", tags_json(s.mannequin_tags, "T_man_tag")}};
  j["tooth"] = {{"kind", "molar"},
                {"voxel_mm", s.tooth_voxel_m * 1e3},
                {"T_man_tooth", pose_json(c.T_man_tooth)}};
  const auto& mp = s.mirror;
  j["mirror"] = {{"radius_mm", c.mirror_radius_m * 1e3},
                 {"thickness_mm", mp.thickness_m * 1e3},
                 {"neck_length_mm", mp.neck_length_m * 1e3},
                 {"neck_radius_mm", mp.neck_radius_m * 1e3},
                 {"handle_length_mm", mp.handle_length_m * 1e3},
                 {"handle_radius_mm", mp.handle_radius_m * 1e3},
                 {"stem_tilt_deg", mp.stem_tilt_rad / kDeg},
                 {"paddle_size_mm", {mp.paddle_width_m * 1e3, mp.paddle_height_m * 1e3}},
                 {"paddle_thickness_mm", mp.paddle_thickness_m * 1e3},
                 {"paddle_roof_deg", mp.paddle_roof_rad / kDeg},
                 {"T_mtag_mir", pose_json(c.T_mtag_mir)},
                 {"tags", tags_json(s.mirror_tags, "T_mtag_tag")}};
  j["haptics"] = {{"T_man_dev", pose_json(c.T_man_dev)}, {"T_sty_tip", pose_json(c.T_sty_tip)}};
  ojson divots = ojson::array(), marks = ojson::array();
  for (const auto& p : s.fixtures.divots_man) divots.push_back(v3(p, 1e3));
  for (const auto& p : s.fixtures.landmarks_tooth) marks.push_back(v3(p, 1e3));
  j["calibration_fixtures"] = {{"divots_mm", divots}, {"tooth_landmarks_mm", marks}};
  ojson rep = ojson::array();
  for (const auto& r : s.calibration_report) {
    ojson figs = ojson::object();
    for (const auto& [name, v] : r.figures) figs[name] = v;
    rep.push_back({{"step", r.step}, {"date", r.date}, {"pass", r.pass}, {"summary", r.summary},
                   {"figures", figs}});
  }
  j["calibration_report"] = rep;
  if (s.hand_eye.present) {
    const HandEyeRecord& h = s.hand_eye;
    ojson hj = {{"T_hand_cam", pose_json(h.T_hand_cam)}, {"hand", h.hand}, {"method", h.method}};
    if (h.rot_sd_rad >= 0) hj["rotation_sd_deg"] = h.rot_sd_rad / kDeg;
    if (h.trans_sd_m >= 0) hj["translation_sd_mm"] = h.trans_sd_m * 1e3;
    hj["rms_rotation_deg"] = h.rms_rot_rad / kDeg;
    hj["rms_mm"] = h.rms_m * 1e3;
    hj["observations"] = h.observations;
    hj["date"] = h.date;
    j["hand_eye"] = hj;
  }
  const StationPolicy& po = s.policy;
  j["station_policy"] = {{"check_threshold_mm", po.check_threshold_m * 1e3},
                         {"max_age_days", po.max_age_days},
                         {"tag_moved_mm", po.tag_moved_m * 1e3},
                         {"tip_check_mm", po.tip_check_m * 1e3},
                         {"health_divot", po.health_divot}};
  if (s.stereo.present) {
    const auto& r = s.stereo.camera_right;
    j["stereo"] = {{"camera_right",
                    {{"width", r.width}, {"height", r.height}, {"fx", r.fx}, {"fy", r.fy},
                     {"cx", r.cx}, {"cy", r.cy}, {"dist", r.dist}}},
                   {"T_left_right", pose_json(s.stereo.T_caml_camr)}};
  }
  // No pen tags: no "pen" block (a file without one reads as the default pen).
  if (!s.pen.tags.empty())
    j["pen"] = {{"flag_size_mm", s.pen.flag_size_m * 1e3},
                {"T_ptag_tip", pose_json(s.pen.T_ptag_tip)},
                {"tags", tags_json(s.pen.tags, "T_ptag_tag")}};
  return compact_number_arrays(j.dump(2)) + "\n";
}

Result<StationScene> parse_station_scene(std::string_view text, const std::string& source) {
  json j;
  try {
    j = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    return Error{source + ": not valid JSON (byte " + std::to_string(e.byte) + "): " + e.what()};
  } catch (const json::exception& e) {  // e.g. out_of_range for 1e400 (found by fuzzing)
    return Error{source + ": not valid JSON: " + e.what()};
  }
  try {
    StationScene s;
    check_keys(j, "",
               {"format", "version", "name", "camera", "tag_family", "mannequin", "tooth", "mirror",
                "haptics", "calibration_fixtures", "calibration_report", "pen", "hand_eye",
                "station_policy", "stereo"});
    if (req(j, "", "format") != "dentar-station")
      throw ParseError{"format", "must be \"dentar-station\""};
    // Files without a version are version 1 (written before the field was required).
    s.version = j.contains("version")
                    ? integer(j["version"], "version", 1, kStationFileVersion)
                    : 1;
    if (s.version < 2)
      for (const char* key : {"calibration_fixtures", "calibration_report"})
        if (j.contains(key))
          throw ParseError{key, "needs version 2 or later (set \"version\": " +
                                    std::to_string(kStationFileVersion) + ")"};
    if (s.version < 3)
      for (const char* key : {"hand_eye", "station_policy"})
        if (j.contains(key))
          throw ParseError{key, "needs version 3 (set \"version\": 3)"};
    if (s.version < 3 && j.contains("camera") && j["camera"].is_object() &&
        j["camera"].contains("device_id"))
      throw ParseError{"camera.device_id", "needs version 3 (set \"version\": 3)"};
    if (s.version < kStationFileVersion) s.migrated_from = s.version;
    if (auto it = j.find("name"); it != j.end()) {
      if (!it->is_string()) throw ParseError{"name", "must be a string"};
      s.name = it->get<std::string>();
    }
    const json& cam0 = req(j, "", "camera");
    json cam = cam0;
    bool cam0_response_seen = false;
    auto& cp = s.camera_provenance;
    if (cam0.is_object() && cam0.contains("response")) {
      // v4: the measured response curve (calibration/response.h).
      if (s.version < 4) throw ParseError{"camera.response", "needs version 4 (set \"version\": 4)"};
      const json& rj = cam0["response"];
      check_keys(rj, "camera.response", {"kind", "curve", "gamma", "gamma_sigma", "views", "edges"});
      auto& r = cp.response;
      const json& kind = req(rj, "camera.response", "kind");
      if (!kind.is_string()) throw ParseError{"camera.response.kind", "must be a string"};
      r.kind = kind.get<std::string>();
      if (rj.contains("curve")) {
        const json& cv = rj["curve"];
        if (!cv.is_array() || cv.size() > 4096)
          throw ParseError{"camera.response.curve", "must be an array of 256 numbers"};
        for (std::size_t i = 0; i < cv.size(); ++i)
          r.table.push_back(number(cv[i], "camera.response.curve[" + std::to_string(i) + "]", 0, 1));
      }
      if (r.kind == "curve" && r.table.empty())
        throw ParseError{"camera.response.curve", "is required with kind \"curve\" (256 numbers)"};
      if (rj.contains("gamma")) r.gamma = number(rj["gamma"], "camera.response.gamma", 0, 10);
      if (rj.contains("gamma_sigma"))
        r.gamma_sigma = number(rj["gamma_sigma"], "camera.response.gamma_sigma", 0, 10);
      if (rj.contains("views")) r.views = integer(rj["views"], "camera.response.views", 0, 1000000);
      if (rj.contains("edges")) r.edges = integer(rj["edges"], "camera.response.edges", 0, 100000000);
      if (std::string e = r.validate("camera.response"); !e.empty()) {
        const auto colon = e.find(' ');
        throw ParseError{e.substr(0, colon), e.substr(colon + 1)};
      }
      cam0_response_seen = true;
    }
    if (cam0.is_object() && cam0.contains("file")) {
      // A referenced camera file (OpenCV FileStorage or ROS camera_info YAML).
      check_keys(cam0, "camera", {"file", "device_id", "response", "latency_ms"});
      if (!cam0["file"].is_string() || cam0["file"].get<std::string>().empty())
        throw ParseError{"camera.file", "must be a non-empty file name"};
      cp.file = cam0["file"].get<std::string>();
      std::filesystem::path fp(cp.file);
      if (fp.is_relative()) fp = std::filesystem::path(source).parent_path() / fp;
      auto cf = calibration::read_camera_file(fp.string());
      if (!cf) throw ParseError{"camera.file", cf.error()};
      const auto& ci = cf->camera;
      cam = {{"width", ci.width}, {"height", ci.height}, {"fx", ci.fx}, {"fy", ci.fy},
             {"cx", ci.cx},       {"cy", ci.cy},         {"dist", ci.dist}};
      cp.model = cf->model;
      cp.rms_px = cf->rms_px;
      cp.std_devs = cf->std_devs;
      cp.date = cf->date;
      cp.device = cf->device;
    }
    if (cam0_response_seen) cam.erase("response");
    if (cam0.is_object() && cam0.contains("device_id")) {
      if (!cam0["device_id"].is_string() || cam0["device_id"].get<std::string>().size() > 256)
        throw ParseError{"camera.device_id", "must be a string of at most 256 characters"};
      cp.device_id = cam0["device_id"].get<std::string>();
      cam.erase("device_id");
    }
    if (cam0.is_object() && cam0.contains("latency_ms")) {
      // Optional in version 4 (issue 24, session 12): absent = unknown (the assumed 33 ms).
      cp.latency_ms = number(cam0["latency_ms"], "camera.latency_ms", 0, 1000);
      cam.erase("latency_ms");
    }
    check_keys(cam, "camera",
               {"width", "height", "fx", "fy", "cx", "cy", "dist", "model", "rms_px", "std_devs",
                "date", "device"});
    if (cp.file.empty()) {
      auto str = [&](const char* key, std::string& out) {
        if (!cam.contains(key)) return;
        if (!cam[key].is_string()) throw ParseError{std::string("camera.") + key, "must be a string"};
        out = cam[key].get<std::string>();
      };
      str("model", cp.model);
      str("date", cp.date);
      str("device", cp.device);
      if (cam.contains("rms_px")) cp.rms_px = number(cam["rms_px"], "camera.rms_px", 0, 100);
      if (cam.contains("std_devs")) {
        const json& sd = cam["std_devs"];
        if (!sd.is_array() || sd.size() > 12)
          throw ParseError{"camera.std_devs", "must be an array of at most 12 numbers"};
        for (std::size_t i = 0; i < sd.size(); ++i)
          cp.std_devs.push_back(
              number(sd[i], "camera.std_devs[" + std::to_string(i) + "]", 0, 1e6));
      }
    }
    auto& k = s.calibration.camera;
    k.width = integer(req(cam, "camera", "width"), "camera.width", 1, 16384);
    k.height = integer(req(cam, "camera", "height"), "camera.height", 1, 16384);
    k.fx = number(req(cam, "camera", "fx"), "camera.fx", 1e-3, 1e6);
    k.fy = number(req(cam, "camera", "fy"), "camera.fy", 1e-3, 1e6);
    k.cx = number(req(cam, "camera", "cx"), "camera.cx", 0, k.width);
    k.cy = number(req(cam, "camera", "cy"), "camera.cy", 0, k.height);
    const auto d = vec<5>(req(cam, "camera", "dist"), "camera.dist", -100, 100);
    for (int i = 0; i < 5; ++i) k.dist[static_cast<std::size_t>(i)] = d[i];
    // The model named must be what the coefficients are (issue 24: a k1 fit is pinhole-k1).
    if (!cp.model.empty()) {
      std::vector<double> dv(k.dist.begin(), k.dist.end());
      if (cp.model == calibration::kModelRational8) dv.clear();  // the file's 8 were checked on read
      if (!dv.empty())
        if (std::string e = calibration::check_model_coefficients(cp.model, dv); !e.empty())
          throw ParseError{cp.file.empty() ? "camera.model" : "camera.file", e};
    }

    const json& fam = req(j, "", "tag_family");
    auto f = fam.is_string() ? parse_tag_family(fam.get<std::string>()) : std::nullopt;
    if (!f) throw ParseError{"tag_family", "must be \"tagStandard41h12\" or \"tag36h11\""};
    s.family = *f;

    const json& mj = req(j, "", "mannequin");
    check_keys(mj, "mannequin",
               {"head_centre_mm", "head_radii_mm", "mouth_half_size_mm", "lip_radius_mm",
                "skin_rgb", "lip_rgb", "gum_rgb", "teeth_rgb", "tags"});
    auto& m = s.mannequin;
    m.head_centre_m =
        vec<3>(req(mj, "mannequin", "head_centre_mm"), "mannequin.head_centre_mm", -1e3, 1e3) *
        1e-3;
    m.head_radii_m =
        vec<3>(req(mj, "mannequin", "head_radii_mm"), "mannequin.head_radii_mm", 30, 300) * 1e-3;
    const auto mouth =
        vec<2>(req(mj, "mannequin", "mouth_half_size_mm"), "mannequin.mouth_half_size_mm", 5, 200);
    m.mouth_half_width_m = mouth[0] * 1e-3;
    m.mouth_half_height_m = mouth[1] * 1e-3;
    m.lip_radius_m =
        number(req(mj, "mannequin", "lip_radius_mm"), "mannequin.lip_radius_mm", 1, 50) * 1e-3;
    m.skin_rgb = vec<3>(req(mj, "mannequin", "skin_rgb"), "mannequin.skin_rgb", 0, 1);
    m.lip_rgb = vec<3>(req(mj, "mannequin", "lip_rgb"), "mannequin.lip_rgb", 0, 1);
    m.gum_rgb = vec<3>(req(mj, "mannequin", "gum_rgb"), "mannequin.gum_rgb", 0, 1);
    m.teeth_rgb = vec<3>(req(mj, "mannequin", "teeth_rgb"), "mannequin.teeth_rgb", 0, 1);
    s.mannequin_tags = tags(req(mj, "mannequin", "tags"), "mannequin.tags", "T_man_tag");

    const json& tj = req(j, "", "tooth");
    check_keys(tj, "tooth", {"kind", "voxel_mm", "T_man_tooth"});
    if (req(tj, "tooth", "kind") != "molar")
      throw ParseError{"tooth.kind", "must be \"molar\" (the procedural molar)"};
    s.tooth_voxel_m = number(req(tj, "tooth", "voxel_mm"), "tooth.voxel_mm", 0.02, 0.5) * 1e-3;
    s.calibration.T_man_tooth = pose(req(tj, "tooth", "T_man_tooth"), "tooth.T_man_tooth");

    const json& rj = req(j, "", "mirror");
    check_keys(rj, "mirror",
               {"radius_mm", "thickness_mm", "neck_length_mm", "neck_radius_mm", "handle_length_mm",
                "handle_radius_mm", "stem_tilt_deg", "paddle_size_mm", "paddle_thickness_mm",
                "paddle_roof_deg", "T_mtag_mir", "tags"});
    auto& mp = s.mirror;
    auto mm = [&](const char* key, double lo, double hi) {
      return number(req(rj, "mirror", key), std::string("mirror.") + key, lo, hi) * 1e-3;
    };
    s.calibration.mirror_radius_m = mm("radius_mm", 2.5, 30);
    mp.thickness_m = mm("thickness_mm", 0.1, 10);
    mp.neck_length_m = mm("neck_length_mm", 1, 100);
    mp.neck_radius_m = mm("neck_radius_mm", 0.2, 10);
    mp.handle_length_m = mm("handle_length_mm", 10, 300);
    mp.handle_radius_m = mm("handle_radius_mm", 0.5, 20);
    mp.stem_tilt_rad =
        number(req(rj, "mirror", "stem_tilt_deg"), "mirror.stem_tilt_deg", -90, 90) * kDeg;
    const auto paddle =
        vec<2>(req(rj, "mirror", "paddle_size_mm"), "mirror.paddle_size_mm", 5, 100);
    mp.paddle_width_m = paddle[0] * 1e-3;
    mp.paddle_height_m = paddle[1] * 1e-3;
    mp.paddle_thickness_m = mm("paddle_thickness_mm", 0.2, 20);
    // Optional (station files before issue 16 have a flat paddle).
    mp.paddle_roof_rad = rj.contains("paddle_roof_deg")
                             ? number(rj["paddle_roof_deg"], "mirror.paddle_roof_deg", 0, 60) * kDeg
                             : 0.0;
    s.calibration.T_mtag_mir = pose(req(rj, "mirror", "T_mtag_mir"), "mirror.T_mtag_mir");
    s.mirror_tags = tags(req(rj, "mirror", "tags"), "mirror.tags", "T_mtag_tag");

    const json& hj = req(j, "", "haptics");
    check_keys(hj, "haptics", {"T_man_dev", "T_sty_tip"});
    s.calibration.T_man_dev = pose(req(hj, "haptics", "T_man_dev"), "haptics.T_man_dev");
    s.calibration.T_sty_tip = pose(req(hj, "haptics", "T_sty_tip"), "haptics.T_sty_tip");

    if (auto it = j.find("calibration_fixtures"); it != j.end()) {
      check_keys(*it, "calibration_fixtures", {"divots_mm", "tooth_landmarks_mm"});
      auto points = [&](const char* key, std::vector<Eigen::Vector3d>& out, double lim) {
        const std::string p = std::string("calibration_fixtures.") + key;
        const json& a = req(*it, "calibration_fixtures", key);
        if (!a.is_array() || a.size() > 64) throw ParseError{p, "must be an array of 0..64 points"};
        for (std::size_t i = 0; i < a.size(); ++i)
          out.push_back(vec<3>(a[i], p + "[" + std::to_string(i) + "]", -lim, lim) * 1e-3);
      };
      points("divots_mm", s.fixtures.divots_man, 1000);
      points("tooth_landmarks_mm", s.fixtures.landmarks_tooth, 100);
    }
    if (auto it = j.find("calibration_report"); it != j.end()) {
      if (!it->is_array() || it->size() > 32)
        throw ParseError{"calibration_report", "must be an array of step reports"};
      for (std::size_t i = 0; i < it->size(); ++i) {
        const std::string p = "calibration_report[" + std::to_string(i) + "]";
        const json& r = (*it)[i];
        check_keys(r, p, {"step", "date", "pass", "summary", "figures"});
        CalibrationStepReport rep;
        auto str = [&](const char* key, std::string& out) {
          const json& v = req(r, p, key);
          if (!v.is_string()) throw ParseError{p + "." + key, "must be a string"};
          out = v.get<std::string>();
        };
        str("step", rep.step);
        str("date", rep.date);
        str("summary", rep.summary);
        const json& pass = req(r, p, "pass");
        if (!pass.is_boolean()) throw ParseError{p + ".pass", "must be true or false"};
        rep.pass = pass.get<bool>();
        const json& figs = req(r, p, "figures");
        if (!figs.is_object()) throw ParseError{p + ".figures", "must be an object of numbers"};
        for (auto f = figs.begin(); f != figs.end(); ++f)
          rep.figures.emplace_back(f.key(), number(f.value(), p + ".figures." + f.key(), -1e12, 1e12));
        s.calibration_report.push_back(rep);
      }
    }

    if (auto it = j.find("hand_eye"); it != j.end()) {
      const json& h = *it;
      check_keys(h, "hand_eye",
                 {"T_hand_cam", "hand", "method", "rotation_sd_deg", "translation_sd_mm",
                  "rms_rotation_deg", "rms_mm", "observations", "date"});
      HandEyeRecord& he = s.hand_eye;
      he.present = true;
      he.T_hand_cam = pose(req(h, "hand_eye", "T_hand_cam"), "hand_eye.T_hand_cam");
      auto str = [&](const char* key, std::string& out) {
        const json& v = req(h, "hand_eye", key);
        if (!v.is_string()) throw ParseError{std::string("hand_eye.") + key, "must be a string"};
        out = v.get<std::string>();
      };
      str("hand", he.hand);
      str("method", he.method);
      str("date", he.date);
      if (h.contains("rotation_sd_deg"))
        he.rot_sd_rad = number(h["rotation_sd_deg"], "hand_eye.rotation_sd_deg", 0, 180) * kDeg;
      if (h.contains("translation_sd_mm"))
        he.trans_sd_m = number(h["translation_sd_mm"], "hand_eye.translation_sd_mm", 0, 1000) * 1e-3;
      he.rms_rot_rad = number(req(h, "hand_eye", "rms_rotation_deg"), "hand_eye.rms_rotation_deg", 0, 180) * kDeg;
      he.rms_m = number(req(h, "hand_eye", "rms_mm"), "hand_eye.rms_mm", 0, 1000) * 1e-3;
      he.observations = integer(req(h, "hand_eye", "observations"), "hand_eye.observations", 0, 100000);
    }
    if (auto it = j.find("station_policy"); it != j.end()) {
      const json& pj = *it;
      check_keys(pj, "station_policy",
                 {"check_threshold_mm", "max_age_days", "tag_moved_mm", "tip_check_mm", "health_divot"});
      StationPolicy& po = s.policy;
      if (pj.contains("check_threshold_mm"))
        po.check_threshold_m = number(pj["check_threshold_mm"], "station_policy.check_threshold_mm", 0.01, 10) * 1e-3;
      if (pj.contains("max_age_days"))
        po.max_age_days = number(pj["max_age_days"], "station_policy.max_age_days", 0.001, 3650);
      if (pj.contains("tag_moved_mm"))
        po.tag_moved_m = number(pj["tag_moved_mm"], "station_policy.tag_moved_mm", 0.01, 50) * 1e-3;
      if (pj.contains("tip_check_mm"))
        po.tip_check_m = number(pj["tip_check_mm"], "station_policy.tip_check_mm", 0.01, 10) * 1e-3;
      if (pj.contains("health_divot"))
        po.health_divot = integer(pj["health_divot"], "station_policy.health_divot", 0, 63);
    }
    if (auto it = j.find("stereo"); it != j.end()) {
      // Issue 28 (optional in version 4): the right eye and the rig's extrinsics.
      check_keys(*it, "stereo", {"camera_right", "T_left_right"});
      const json& cr = req(*it, "stereo", "camera_right");
      check_keys(cr, "stereo.camera_right", {"width", "height", "fx", "fy", "cx", "cy", "dist"});
      auto& r = s.stereo.camera_right;
      const std::string p = "stereo.camera_right";
      r.width = integer(req(cr, p, "width"), p + ".width", 1, 16384);
      r.height = integer(req(cr, p, "height"), p + ".height", 1, 16384);
      r.fx = number(req(cr, p, "fx"), p + ".fx", 1e-3, 1e6);
      r.fy = number(req(cr, p, "fy"), p + ".fy", 1e-3, 1e6);
      r.cx = number(req(cr, p, "cx"), p + ".cx", 0, r.width);
      r.cy = number(req(cr, p, "cy"), p + ".cy", 0, r.height);
      const auto d = vec<5>(req(cr, p, "dist"), p + ".dist", -100, 100);
      for (int i = 0; i < 5; ++i) r.dist[static_cast<std::size_t>(i)] = d[i];
      s.stereo.T_caml_camr = pose(req(*it, "stereo", "T_left_right"), "stereo.T_left_right");
      s.stereo.present = true;
    }
    if (auto it = j.find("pen"); it != j.end()) {
      check_keys(*it, "pen", {"flag_size_mm", "T_ptag_tip", "tags"});
      s.pen.flag_size_m = number(req(*it, "pen", "flag_size_mm"), "pen.flag_size_mm", 5, 200) * 1e-3;
      s.pen.T_ptag_tip = pose(req(*it, "pen", "T_ptag_tip"), "pen.T_ptag_tip");
      s.pen.tags = tags(req(*it, "pen", "tags"), "pen.tags", "T_ptag_tag");
    } else {
      s.pen = default_pen();
    }
    if (std::string e = s.validate(); !e.empty()) return Error{source + ": " + e};
    return s;
  } catch (const ParseError& e) {
    return Error{source + ": " + e.path + ": " + e.message};
  } catch (const json::exception& e) {
    return Error{source + ": " + e.what()};
  }
}

Result<StationScene> read_station_scene(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot open the station file"};
  std::ostringstream os;
  os << in.rdbuf();
  if (os.str().size() > (std::size_t{1} << 22))
    return Error{path + ": over 4 MiB, not a station file"};
  return parse_station_scene(os.str(), path);
}

Status write_station_scene(const StationScene& s, const std::string& path) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return Error{"dentar::ar::write_station_scene: cannot open for writing '" + path + "'"};
    out << station_scene_to_json(s);
    out.close();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      return Error{"dentar::ar::write_station_scene: write failed for '" + path + "'"};
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return Error{"dentar::ar::write_station_scene: cannot replace '" + path + "': " + ec.message()};
  }
  return {};
}

}  // namespace dentar::ar
