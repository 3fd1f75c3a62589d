// frames.csv: the state names and both row layouts. See frames_csv.h.
#include "dentar/session/frames_csv.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace dentar::session {

const char* state_name(TrackState s) { return ar::track_state_name(s); }

const char* state_name(int s) {
  return s >= 0 && s <= 2 ? ar::track_state_name(static_cast<TrackState>(s)) : ar::track_state_name(TrackState::kLost);
}

Result<TrackState> parse_state(const std::string& name) {
  for (TrackState s : {TrackState::kTracking, TrackState::kPredicted, TrackState::kLost})
    if (name == ar::track_state_name(s)) return s;
  return Error{"state \"" + name + "\" must be tracking, predicted or lost"};
}

namespace {

// 12 numbers, row-major 3x4, or empty when lost.
std::string pose_3x4(int state, const Eigen::Isometry3d& T) {
  if (state == static_cast<int>(TrackState::kLost)) return {};
  std::ostringstream s;
  s << std::setprecision(17);
  const Eigen::Matrix4d m = T.matrix();
  for (int i = 0; i < 12; ++i) s << (i ? " " : "") << m(i / 4, i % 4);
  return s.str();
}

}  // namespace

const char* eyes_name(int eyes) {
  switch (eyes) {
    case ar::FrameRecord::kEyesBoth: return "both";
    case ar::FrameRecord::kEyesLeft: return "left";
    case ar::FrameRecord::kEyesRight: return "right";
    default: return "";
  }
}

std::string recording_csv_header(bool stereo) {
  return std::string("frame,time_s,steady_s,source_index,haptic_steps,man_state,mirror_state,pen_state,"
                     "man_T,mirror_T,pedal,force_N,overlay,track_ms,mesh_ms,composite_ms,disc_start,disc_merged,"
                     "pose_step") +
         (stereo ? ",eyes,right_composited,right_overlay,right_mirror_drawn,right_composite_ms\n" : "\n");
}

std::string recording_csv_row(const ar::FrameRecord& r, std::int64_t index, double steady_s,
                              std::int64_t source_index, bool stereo) {
  std::ostringstream s;
  s << std::setprecision(17) << index << ',' << r.time_s << ',' << steady_s << ',' << source_index << ','
    << r.haptic_steps_done << ',' << state_name(r.man_state) << ',' << state_name(r.mir_state) << ','
    << state_name(r.pen_state) << ',' << pose_3x4(r.man_state, r.T_cam_man) << ','
    << pose_3x4(r.mir_state, r.T_cam_mtag) << ',' << (r.pedal ? 1 : 0) << ',' << std::setprecision(6) << r.force_N
    << ',' << (r.overlay ? 1 : 0) << ',' << r.track_ms << ',' << r.mesh_ms << ',' << r.composite_ms << ','
    << (r.disc_start ? 1 : 0) << ',' << r.disc_merged << ',' << std::setprecision(17) << r.pose_step;
  if (stereo)
    s << ',' << eyes_name(r.eyes) << ',' << (r.right.composited ? 1 : 0) << ',' << (r.right.overlay ? 1 : 0) << ','
      << (r.right.mirror_drawn ? 1 : 0) << ',' << std::setprecision(6) << r.right.composite_ms;
  s << '\n';
  return s.str();
}

std::string offline_csv_header(bool stereo) {
  std::string h =
      "frame,time_s,man_state,man_tx_mm,man_ty_mm,man_tz_mm,man_qw,man_qx,man_qy,man_qz,man_rms_px,"
      "man_tags,mirror_state,mirror_tx_mm,mirror_ty_mm,mirror_tz_mm,mirror_qw,mirror_qx,mirror_qy,"
      "mirror_qz,mirror_tags,tags_detected,full_frame,haptic_step,pedal,overlay,mirror_drawn,triangles";
  for (int m = 1; m < volume::kNumMaterials; ++m) h += ",removed_" + std::string(volume::material_info(m).name) + "_mm3";
  h += ",man_err_mm,man_err_deg,tooth_err_px,tip_err_mm,silhouette_iou,mir_err_mm,mir_err_deg,"
       "read_ms,detect_ms,pose_ms,filter_ms,track_ms,haptics_ms,mesh_ms,composite_ms,write_ms,latency_ms";
  h += stereo ? ",eyes,man_views,mirror_views,right_composited,right_overlay,right_mirror_drawn,right_composite_ms,"
                "right_tooth_err_px,right_silhouette_iou\n"
              : "\n";
  return h;
}

std::string offline_csv_row(const OfflineFrameRow& r, bool stereo) {
  std::ostringstream s;
  s << std::setprecision(9);
  auto num = [&](double x) {
    if (std::isfinite(x)) s << x;
    s << ',';
  };
  auto pose = [&](int state, const Eigen::Isometry3d& T) {
    if (state == static_cast<int>(TrackState::kLost)) {
      s << ",,,,,,,";
      return;
    }
    const Eigen::Quaterniond q(T.linear());
    for (int i = 0; i < 3; ++i) num(T.translation()[i] * 1e3);
    num(q.w()), num(q.x()), num(q.y()), num(q.z());
  };
  s << r.frame << ',' << r.time_s << ',' << state_name(r.man_state) << ',';
  pose(r.man_state, r.T_cam_man);
  num(r.man_rms_px);
  s << r.man_tags << ',' << state_name(r.mir_state) << ',';
  pose(r.mir_state, r.T_cam_mtag);
  s << r.mir_tags << ',' << r.tags_detected << ',' << (r.full_frame ? 1 : 0) << ',' << r.haptic_step << ','
    << (r.pedal ? 1 : 0) << ',' << (r.overlay ? 1 : 0) << ',' << (r.mirror_drawn ? 1 : 0) << ',' << r.triangles
    << ',';
  for (int m = 1; m < volume::kNumMaterials; ++m) num(r.removed_mm3[m]);
  for (double x : {r.man_err_mm, r.man_err_deg, r.tooth_err_px, r.tip_err_mm, r.iou, r.mir_err_mm, r.mir_err_deg,
                   r.read_ms, r.detect_ms, r.pose_ms, r.filter_ms, r.track_ms, r.haptics_ms, r.mesh_ms,
                   r.composite_ms, r.write_ms})
    num(x);
  s << r.latency_ms;
  if (stereo) {
    s << ',' << eyes_name(r.eyes) << ',' << r.man_views << ',' << r.mir_views << ',' << (r.right_composited ? 1 : 0)
      << ',' << (r.right_overlay ? 1 : 0) << ',' << (r.right_mirror_drawn ? 1 : 0) << ',';
    num(r.right_composite_ms);
    num(r.right_tooth_err_px);
    if (std::isfinite(r.right_iou)) s << r.right_iou;
  }
  s << '\n';
  return s.str();
}

namespace {

// One CSV row's cells (no quoting in frames.csv; a trailing \r is dropped).

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> v;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      v.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  v.push_back(cur);
  return v;
}

bool to_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end && *end == '\0' && std::isfinite(out);
}

}  // namespace

Result<std::vector<training::ViewFrame>> read_view_frames(const std::string& path, double rate_hz) {
  std::ifstream f(path);
  if (!f) return Error{path + ": cannot open"};
  if (!(rate_hz > 0)) return Error{path + ": the session's haptic rate must be positive"};
  std::string line;
  if (!std::getline(f, line)) return Error{path + ": empty (expected a header row)"};
  const std::vector<std::string> head = split(line);
  auto col = [&](const std::string& n) -> int {
    for (std::size_t i = 0; i < head.size(); ++i)
      if (head[i] == n) return static_cast<int>(i);
    return -1;
  };
  const bool live = col("man_T") >= 0;
  const int c_step = live ? col("haptic_steps") : col("haptic_step");
  const int c_pedal = col("pedal");
  const int c_mst = col("man_state"), c_rst = col("mirror_state");
  int c_man = live ? col("man_T") : col("man_tx_mm");
  int c_mir = live ? col("mirror_T") : col("mirror_tx_mm");
  if (c_step < 0 || c_pedal < 0 || c_mst < 0 || c_rst < 0 || c_man < 0 || c_mir < 0)
    return Error{path + ": line 1: not a frames.csv of `dentar offline` or `dentar live --record` (needs " +
                 std::string(live ? "haptic_steps, man_T, mirror_T" : "haptic_step, man_tx_mm.., mirror_tx_mm..") +
                 ", man_state, mirror_state and pedal)"};
  if (!live && (col("man_qz") != c_man + 6 || col("mirror_qz") != c_mir + 6))
    return Error{path + ": line 1: expected man_tx_mm..man_qz and mirror_tx_mm..mirror_qz as 7 adjacent columns"};
  std::vector<training::ViewFrame> out;
  int ln = 1;
  while (std::getline(f, line)) {
    ++ln;
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> v = split(line);
    const auto need = static_cast<std::size_t>(std::max({c_step, c_pedal, c_mst, c_rst, c_man + (live ? 0 : 6),
                                                         c_mir + (live ? 0 : 6)}));
    // A row cut short by a crash ends the table (as the offline replay reads it).
    if (v.size() <= need) break;
    auto where = [&](int c) {
      return path + ": line " + std::to_string(ln) + ", column " + std::to_string(c + 1) + " (" + head[static_cast<std::size_t>(c)] + ")";
    };
    training::ViewFrame fr;
    double steps = 0;
    if (!to_double(v[static_cast<std::size_t>(c_step)], steps) || steps < 0)
      return Error{where(c_step) + ": '" + v[static_cast<std::size_t>(c_step)] + "' is not a step count"};
    fr.session_s = steps / rate_hz;
    fr.pedal = v[static_cast<std::size_t>(c_pedal)] == "1";
    auto pose = [&](int c_state, int c0, std::optional<Eigen::Isometry3d>& T) -> Status {
      const std::string& st = v[static_cast<std::size_t>(c_state)];
      // Poses as drawn: tracking or predicted (a lost body's cells are empty; an unknown name is lost).
      const auto state = parse_state(st);
      if (!state || *state == TrackState::kLost) return {};
      Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
      if (live) {
        std::istringstream ss(v[static_cast<std::size_t>(c0)]);
        double x[12];
        for (double& e : x)
          if (!(ss >> e) || !std::isfinite(e)) return Error{where(c0) + ": expected 12 numbers (3x4 pose, row-major, m)"};
        for (int i = 0; i < 12; ++i) M.matrix()(i / 4, i % 4) = x[i];
      } else {
        double x[7];
        for (int i = 0; i < 7; ++i)
          if (!to_double(v[static_cast<std::size_t>(c0 + i)], x[i]))
            return Error{where(c0 + i) + ": '" + v[static_cast<std::size_t>(c0 + i)] + "' is not a number (state " + st + ")"};
        Eigen::Quaterniond q(x[3], x[4], x[5], x[6]);
        if (q.norm() < 0.5) return Error{where(c0 + 3) + ": quaternion of length " + std::to_string(q.norm())};
        M.linear() = q.normalized().toRotationMatrix();
        M.translation() = Eigen::Vector3d(x[0], x[1], x[2]) * 1e-3;
      }
      T = M;
      return {};
    };
    if (Status s = pose(c_mst, c_man, fr.T_cam_man); !s) return Error{s.error()};
    if (Status s = pose(c_rst, c_mir, fr.T_cam_mtag); !s) return Error{s.error()};
    out.push_back(std::move(fr));
  }
  if (out.empty()) return Error{path + ": no frame rows"};
  return out;
}

}  // namespace dentar::session
