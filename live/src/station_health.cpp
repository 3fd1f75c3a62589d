// Station health checks at the start of `dentar live`. See station_health.h.
#include "dentar/live/station_health.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/camera_model.h"
#include "dentar/training/exercise.h"
#include "dentar/volume/procedural_incisor.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::live {
namespace {

std::string mm(double m, int prec = 2) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(prec) << m * 1e3;
  return os.str();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

const char* health_level_name(HealthLevel l) {
  switch (l) {
    case HealthLevel::kOk: return "ok";
    case HealthLevel::kNote: return "note";
    case HealthLevel::kWarning: return "warning";
    case HealthLevel::kInstructor: return "instructor needed";
  }
  return "?";
}

void StationHealth::set(const HealthItem& item) {
  for (auto& i : items)
    if (i.check == item.check) {
      i = item;
      return;
    }
  items.push_back(item);
}

HealthLevel StationHealth::worst() const {
  HealthLevel w = HealthLevel::kOk;
  for (const auto& i : items) w = std::max(w, i.level);
  return w;
}

bool StationHealth::instructor_needed() const { return worst() == HealthLevel::kInstructor; }

std::string StationHealth::headline() const {
  for (HealthLevel l : {HealthLevel::kInstructor, HealthLevel::kWarning, HealthLevel::kNote})
    for (const auto& i : items)
      if (i.level == l)
        return std::string(l == HealthLevel::kInstructor ? "INSTRUCTOR NEEDED: "
                           : l == HealthLevel::kWarning  ? "station warning: "
                                                         : "") +
               i.check + ": " + i.message;
  return "station OK";
}

std::optional<double> age_days(const std::string& iso, double now_unix) {
  std::tm tm{};
  int y, mo, d, h, mi, s;
  char z = 0;
  if (std::sscanf(iso.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%c", &y, &mo, &d, &h, &mi, &s, &z) != 7 || z != 'Z')
    return std::nullopt;
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || s > 60) return std::nullopt;
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  const double t = static_cast<double>(timegm(&tm));
  return (now_unix - t) / 86400.0;
}

std::vector<HealthItem> check_station_file(const ar::StationScene& st, bool builtin, double now_unix,
                                           const std::string& camera_identity) {
  std::vector<HealthItem> out;
  if (builtin) {
    out.push_back({"station", HealthLevel::kNote,
                   "uncalibrated (built-in intrinsics): the built-in station \"" + st.name +
                       "\" is not calibrated for this bench; fine for a try-out (for training, an instructor "
                       "calibrates the station: dentar calibrate)"});
    return out;
  }
  const auto& po = st.policy;
  // Camera identity.
  const std::string& want = st.camera_provenance.device_id;
  if (!want.empty() && !camera_identity.empty() && want != camera_identity)
    out.push_back({"camera", HealthLevel::kInstructor,
                   "the station file was calibrated with camera \"" + want + "\", but this camera is \"" +
                       camera_identity + "\": use the station file made for this camera, or an instructor "
                       "calibrates it (dentar calibrate camera)"});
  // Age: every result is only as fresh as the oldest step on record.
  if (st.calibration_report.empty()) {
    out.push_back({"calibration age", HealthLevel::kInstructor,
                   "the station file holds no calibration (no calibration_report): an instructor must "
                   "calibrate the station (dentar calibrate)"});
  } else {
    double oldest = -1;
    std::string oldest_step, bad_date;
    for (const auto& r : st.calibration_report) {
      const auto a = age_days(r.date, now_unix);
      if (!a) {
        bad_date = r.step;
        continue;
      }
      if (*a > oldest) {
        oldest = *a;
        oldest_step = r.step;
      }
    }
    std::ostringstream os;
    os << std::fixed << std::setprecision(0);
    if (!bad_date.empty()) {
      out.push_back({"calibration age", HealthLevel::kInstructor,
                     "the " + bad_date + " step has no readable date: an instructor should re-run it"});
    } else if (oldest > po.max_age_days) {
      os << "calibrated " << oldest << " days ago (the " << oldest_step << " step; this station's limit is "
         << po.max_age_days << " days, station_policy.max_age_days): an instructor should check the station "
         << "(dentar calibrate check) and redo the steps that fail";
      out.push_back({"calibration age", HealthLevel::kInstructor, os.str()});
    } else {
      os << "calibrated " << std::max(0.0, oldest) << " days ago (limit " << po.max_age_days << ")";
      out.push_back({"calibration age", HealthLevel::kOk, os.str()});
    }
  }
  // The end-to-end check.
  const ar::CalibrationStepReport* chk = st.step_report("check");
  if (!st.calibration_report.empty()) {
    if (!chk) {
      out.push_back({"station check", HealthLevel::kInstructor,
                     "the station was never checked end to end: an instructor runs dentar calibrate check"});
    } else if (!chk->pass) {
      out.push_back({"station check", HealthLevel::kInstructor,
                     "the last station check (" + chk->date + ") FAILED: an instructor must recalibrate"});
    } else {
      const auto check_age = age_days(chk->date, now_unix);
      std::string newer;
      for (const auto& r : st.calibration_report) {
        const auto a = age_days(r.date, now_unix);
        if (r.step != "check" && a && check_age && *a < *check_age) newer = r.step;
      }
      if (!newer.empty())
        out.push_back({"station check", HealthLevel::kWarning,
                       "the " + newer + " step was redone after the last check (" + chk->date +
                           "): run dentar calibrate check"});
      else
        out.push_back({"station check", HealthLevel::kOk, "passed on " + chk->date});
    }
  }
  return out;
}

// ---- tag layout ----------------------------------------------------------------------------

TagLayoutCheck::TagLayoutCheck(const ar::StationScene& st, int frames_needed)
    : st_(st), frames_needed_(std::max(1, frames_needed)) {}

void TagLayoutCheck::add(const std::vector<ar::DetectedTag>& detections) {
  if (done()) return;
  const ar::TagBundle bundle = ar::mannequin_bundle(st_);
  std::vector<const ar::DetectedTag*> mine;
  for (const auto& d : detections)
    if (d.family == st_.family)
      for (const auto& t : bundle.tags)
        if (t.id == d.id) mine.push_back(&d);
  if (mine.size() < 3) return;  // leave-one-out needs two others at least
  const auto& k = st_.calibration.camera;
  const ar::CameraModel cam(k);
  // Tag i's displacement (m) predicted from the bundle pose of the other tags, minus `skip`.
  auto displacement = [&](std::size_t i, std::size_t skip) -> double {
    std::vector<ar::DetectedTag> others;
    for (std::size_t j = 0; j < mine.size(); ++j)
      if (j != i && j != skip) others.push_back(*mine[j]);
    if (others.size() < 2) return -1;
    const ar::BundlePose p = ar::estimate_bundle_pose(bundle, k, others);
    const ar::TagPlacement* tp = st_.find_tag(mine[i]->id);
    if (!p.ok() || !tp) return -1;
    double px = 0;
    for (int c = 0; c < 4; ++c) {
      const auto q = cam.project(p.T_cam_body * tp->corner(c));
      if (!q) return -1;
      px += (*q - mine[i]->corners_px[static_cast<std::size_t>(c)]).norm();
    }
    const double z = (p.T_cam_body * tp->T_parent_tag.translation()).z();
    return px / 4 * z / k.fx;  // pixels to metres at the tag's depth
  };
  std::vector<double> d(mine.size());
  std::size_t worst = 0;
  for (std::size_t i = 0; i < mine.size(); ++i) {
    d[i] = displacement(i, mine.size());
    if (d[i] > d[worst]) worst = i;
  }
  // One moved tag also pulls the poses the others are checked against: when one stands out,
  // check the others without it too (leave two out).
  if (mine.size() >= 4 && d[worst] > 0.5 * st_.policy.tag_moved_m)
    for (std::size_t i = 0; i < mine.size(); ++i)
      if (i != worst) {
        const double e = displacement(i, worst);
        if (e >= 0) d[i] = e;
      }
  bool any = false;
  for (std::size_t i = 0; i < mine.size(); ++i)
    if (d[i] >= 0) {
      disp_[mine[i]->id].push_back(d[i]);
      any = true;
    }
  if (any) ++frames_;
}

std::map<int, double> TagLayoutCheck::displacement_m() const {
  std::map<int, double> out;
  for (const auto& [id, v] : disp_) out[id] = median(v);
  return out;
}

HealthItem TagLayoutCheck::result() const {
  HealthItem it{"tag layout", HealthLevel::kOk, ""};
  if (!done()) {
    it.level = HealthLevel::kNote;  // still looking: nothing is wrong yet
    it.message = "not checked yet: the mannequin was seen with 3 or more tags in " + std::to_string(frames_) +
                 " of the " + std::to_string(frames_needed_) + " frames needed";
    return it;
  }
  const double lim = st_.policy.tag_moved_m;
  std::vector<std::pair<double, int>> moved;
  double worst = 0;
  for (const auto& [id, d] : displacement_m()) {
    worst = std::max(worst, d);
    if (d > lim) moved.emplace_back(d, id);
  }
  std::sort(moved.rbegin(), moved.rend());
  if (moved.empty()) {
    std::vector<std::pair<std::size_t, int>> seen;  // (frames, id): most seen first
    for (const auto& [id, v] : disp_) seen.emplace_back(v.size(), id);
    std::sort(seen.begin(), seen.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    std::string ids;
    for (const auto& [n, id] : seen) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    it.message = std::to_string(disp_.size()) + " tags where the calibration put them (most seen first: " + ids +
                 "; worst " + mm(worst) + " mm, limit " + mm(lim) + " mm)";
    return it;
  }
  std::ostringstream os;
  os << "mannequin tag" << (moved.size() > 1 ? "s " : " ");
  for (std::size_t i = 0; i < moved.size(); ++i)
    os << (i ? ", " : "") << moved[i].second << " (" << mm(moved[i].first) << " mm)";
  os << (moved.size() > 1 ? " are" : " is") << " not where the station file puts " << (moved.size() > 1 ? "them" : "it")
     << " (limit " << mm(lim) << " mm, station_policy.tag_moved_mm): moved or re-stuck since calibration. "
     << "An instructor puts the tag back or recalibrates the station";
  it.level = HealthLevel::kInstructor;
  it.message = os.str();
  return it;
}

// ---- stylus tip at the health divot ----------------------------------------------------------

DivotTouchCheck::DivotTouchCheck(const ar::StationScene& st) : st_(st) {
  const int i = st.policy.health_divot;
  if (i >= 0 && i < static_cast<int>(st.fixtures.divots_man.size())) {
    available_ = true;
    divot_man_ = st.fixtures.divots_man[static_cast<std::size_t>(i)];
  }
  capture_radius_m_ = std::max(4e-3, 4 * st.policy.tip_check_m);
}

std::optional<HealthItem> DivotTouchCheck::add(double t_s, const Eigen::Isometry3d& T_dev_sty, bool valid) {
  if (!available_ || done_) return std::nullopt;
  if (!valid) {
    touch_.clear();
    return std::nullopt;
  }
  const auto& c = st_.calibration;
  const Eigen::Vector3d tip = (c.T_man_dev * T_dev_sty * c.T_sty_tip).translation();
  if ((tip - divot_man_).norm() > capture_radius_m_) {
    touch_.clear();
    return std::nullopt;
  }
  touch_.add(t_s, tip);
  if (!touch_.still()) return std::nullopt;
  const calibration::TouchResult r = touch_.take("health divot");
  if (!r.ok) return std::nullopt;
  done_ = true;
  error_m_ = (r.tip - divot_man_).norm();
  const double lim = st_.policy.tip_check_m;
  HealthItem it{"stylus tip", HealthLevel::kOk, ""};
  const std::string which = "divot " + std::to_string(st_.policy.health_divot);
  if (error_m_ <= lim) {
    it.message = "the bur tip is " + mm(error_m_) + " mm from " + which + " (limit " + mm(lim) + " mm)";
  } else {
    it.level = HealthLevel::kInstructor;
    it.message = "the bur tip is " + mm(error_m_) + " mm from " + which + " (limit " + mm(lim) +
                 " mm, station_policy.tip_check_mm): the stylus, its bur or the device base moved since "
                 "calibration. An instructor re-runs dentar calibrate pivot and register";
  }
  return it;
}

}  // namespace dentar::live

namespace dentar::live {

StationHealthMonitor::StationHealthMonitor(const ar::StationScene& st, bool builtin, double now_unix,
                                           const std::string& camera_identity)
    : layout_(st), divot_(st), builtin_(builtin) {
  for (const auto& it : check_station_file(st, builtin, now_unix, camera_identity)) health_.set(it);
  health_.set(layout_.result());
  if (!builtin && divot_.available())
    health_.set({"stylus tip", HealthLevel::kWarning,
                 "not checked yet: hold the bur tip still in divot " + std::to_string(st.policy.health_divot) +
                     " for a second"});
}

std::vector<HealthItem> StationHealthMonitor::on_frame(const std::vector<ar::DetectedTag>& detections, double t_s,
                                                       const Eigen::Isometry3d& T_dev_sty, bool stylus_valid) {
  std::vector<HealthItem> changed;
  if (!layout_.done()) {
    layout_.add(detections);
    if (layout_.done()) {
      HealthItem it = layout_.result();
      if (builtin_ && it.level == HealthLevel::kInstructor) {
        it.level = HealthLevel::kWarning;  // nothing was calibrated: no alarm, placement is approximate
        it.message += " (a built-in station: the tooth is placed approximately; check that the kit was "
                      "printed at 100 % and taped flat)";
      }
      changed.push_back(it);
    }
  }
  if (!builtin_)
    if (auto it = divot_.add(t_s, T_dev_sty, stylus_valid)) changed.push_back(*it);
  if (!changed.empty()) {
    std::lock_guard<std::mutex> lock(m_);
    for (const auto& it : changed) health_.set(it);
  }
  return changed;
}

StationHealth StationHealthMonitor::health() const {
  std::lock_guard<std::mutex> lock(m_);
  return health_;
}

std::optional<HealthItem> StationHealthMonitor::refusal() const {
  std::lock_guard<std::mutex> lock(m_);
  for (const auto& it : health_.items)
    if (it.check == "camera" && it.level == HealthLevel::kInstructor) return it;
  return std::nullopt;
}

}  // namespace dentar::live

namespace dentar::live {

Result<Eigen::AlignedBox3d> crown_box_tooth(const ar::StationScene& st) {
  volume::MolarParams mp;
  mp.voxel_mm = 1e3 * st.tooth_voxel_m;
  return crown_box_tooth(nlohmann::json{{"kind", "molar"}, {"voxel_mm", mp.voxel_mm}}.dump());
}

Result<Eigen::AlignedBox3d> crown_box_tooth(const std::string& tooth_json) {
  auto j = nlohmann::json::parse(tooth_json, nullptr, false);
  const std::string kind = j.is_object() ? j.value("kind", std::string()) : std::string();
  // The crown's height above the cervical line, from the tooth's own parameters.
  double crown_mm = 0;
  if (kind == "molar") crown_mm = volume::MolarParams{}.crown_height_mm;
  else if (kind == "incisor") crown_mm = volume::IncisorParams{}.crown_length_mm;
  else return Error{"tooth " + tooth_json + ": no crown height known for this kind (molar, incisor)"};
  auto tooth = training::make_tooth(tooth_json);
  if (!tooth) return Error{"tooth " + tooth_json + ": " + tooth.error()};
  Eigen::AlignedBox3d box;
  const volume::VoxelVolume& v = *tooth;
  for (int k = 0; k < v.dims().z(); ++k)
    for (int j = 0; j < v.dims().y(); ++j)
      for (int i = 0; i < v.dims().x(); ++i)
        if (v.density(i, j, k) > 127)
          box.extend(Eigen::Vector3d(v.origin() + v.spacing().cwiseProduct(Eigen::Vector3d(i, j, k))));
  if (box.isEmpty()) return Error{"tooth " + tooth_json + ": no solid voxel"};
  box.min().z() = std::max(box.min().z(), box.max().z() - 1e-3 * crown_mm);
  return box;
}

std::string describe_move_man(const ar::StationScene& st, const Eigen::Vector3d& d) {
  // The box station's mannequin frame is its tag board (station_scene.h, box_station_scene).
  const bool board = st.name.rfind("box", 0) == 0;
  static const char* kHead[3][2] = {{"toward the patient's left", "toward the patient's right"},
                                    {"up", "down"},
                                    {"toward the face (forward)", "back toward the head"}};
  static const char* kBoard[3][2] = {{"toward tags 2 and 5", "toward tags 0 and 3"},
                                     {"toward the tags 0..2 row", "toward the tags 3..5 row"},
                                     {"up off the board", "down toward the board"}};
  std::ostringstream os;
  os << std::fixed << std::setprecision(0) << d.norm() * 1e3 << " mm";
  const char* sep = ": ";
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-3) continue;
    os << sep << std::abs(d[a]) * 1e3 << " mm " << (board ? kBoard : kHead)[a][d[a] > 0 ? 0 : 1];
    sep = ", ";
  }
  os << (board ? " (board frame)" : " (mannequin frame)");
  return os.str();
}

StationReach check_station_reach(const ar::StationScene& st, const haptics::DeviceLimits& limits,
                                 const std::string& device, const Eigen::AlignedBox3d& crown_tooth) {
  StationReach out;
  const auto& c = st.calibration;
  const Eigen::Isometry3d T_tooth_dev = c.T_tooth_dev();
  out.reach = haptics::check_reach(limits, T_tooth_dev, c.T_sty_tip, crown_tooth);
  out.move_man_m = c.T_man_tooth.linear() * out.reach.move_tooth_m;
  // Registration touches the divots: each is a point the tip must reach (a box of no extent).
  for (std::size_t i = 0; i < st.fixtures.divots_man.size(); ++i) {
    const Eigen::Vector3d p = c.T_man_tooth.inverse() * st.fixtures.divots_man[i];
    Eigen::AlignedBox3d pt(p, p);
    pt.extend(p + Eigen::Vector3d::Constant(1e-9));
    if (!haptics::check_reach(limits, T_tooth_dev, c.T_sty_tip, pt).reachable)
      out.divots_out_of_reach.push_back(static_cast<int>(i));
  }
  HealthItem& it = out.item;
  it.check = "stylus reach";
  std::ostringstream os;
  if (out.reach.reachable) {
    it.level = HealthLevel::kOk;
    os << device << " reaches the whole crown (farthest point " << mm(out.reach.worst_distance_m, 0)
       << " mm from its workspace centre, reach " << mm(out.reach.reach_m, 0) << " mm)";
  } else {
    it.level = HealthLevel::kInstructor;
    os << device << " cannot reach the whole crown: its farthest point is " << mm(out.reach.worst_distance_m, 0)
       << " mm from the device's workspace centre, " << mm(out.reach.worst_distance_m - out.reach.reach_m, 0)
       << " mm beyond its reach of " << mm(out.reach.reach_m, 0) << " mm. ";
    if (out.reach.movable)
      os << "Move the device " << describe_move_man(st, out.move_man_m)
         << ", then an instructor re-runs dentar calibrate register";
    else
      os << "No placement of this device reaches all of it: use a device with a larger workspace";
  }
  if (!out.divots_out_of_reach.empty()) {
    os << "; registration divots out of reach from there:";
    for (int i : out.divots_out_of_reach) os << " " << i;
  }
  it.message = os.str();
  return out;
}

void StationHealthMonitor::set(const HealthItem& item) {
  std::lock_guard<std::mutex> lock(m_);
  health_.set(item);
}

}  // namespace dentar::live
