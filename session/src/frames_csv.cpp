// frames.csv: the state names and both row layouts. See frames_csv.h.
#include "dentar/session/frames_csv.h"

#include <cmath>
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

std::string recording_csv_header() {
  return "frame,time_s,steady_s,source_index,haptic_steps,man_state,mirror_state,pen_state,"
         "man_T,mirror_T,pedal,force_N,overlay,track_ms,mesh_ms,composite_ms,disc_start,disc_merged,pose_step\n";
}

std::string recording_csv_row(const ar::FrameRecord& r, std::int64_t index, double steady_s,
                              std::int64_t source_index) {
  std::ostringstream s;
  s << std::setprecision(17) << index << ',' << r.time_s << ',' << steady_s << ',' << source_index << ','
    << r.haptic_steps_done << ',' << state_name(r.man_state) << ',' << state_name(r.mir_state) << ','
    << state_name(r.pen_state) << ',' << pose_3x4(r.man_state, r.T_cam_man) << ','
    << pose_3x4(r.mir_state, r.T_cam_mtag) << ',' << (r.pedal ? 1 : 0) << ',' << std::setprecision(6) << r.force_N
    << ',' << (r.overlay ? 1 : 0) << ',' << r.track_ms << ',' << r.mesh_ms << ',' << r.composite_ms << ','
    << (r.disc_start ? 1 : 0) << ',' << r.disc_merged << ',' << std::setprecision(17) << r.pose_step << '\n';
  return s.str();
}

std::string offline_csv_header() {
  std::string h =
      "frame,time_s,man_state,man_tx_mm,man_ty_mm,man_tz_mm,man_qw,man_qx,man_qy,man_qz,man_rms_px,"
      "man_tags,mirror_state,mirror_tx_mm,mirror_ty_mm,mirror_tz_mm,mirror_qw,mirror_qx,mirror_qy,"
      "mirror_qz,mirror_tags,tags_detected,full_frame,haptic_step,pedal,overlay,mirror_drawn,triangles";
  for (int m = 1; m < volume::kNumMaterials; ++m) h += ",removed_" + std::string(volume::material_info(m).name) + "_mm3";
  h += ",man_err_mm,man_err_deg,tooth_err_px,tip_err_mm,silhouette_iou,mir_err_mm,mir_err_deg,"
       "read_ms,detect_ms,pose_ms,filter_ms,track_ms,haptics_ms,mesh_ms,composite_ms,write_ms,latency_ms\n";
  return h;
}

std::string offline_csv_row(const OfflineFrameRow& r) {
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
  s << r.latency_ms << '\n';
  return s.str();
}

}  // namespace dentar::session
