// frames.csv, the per-frame table of a run (docs/formats.md): the one place
// that names the tracking states and writes the rows, in the two layouts the
// runs keep:
//  - the live recording's (`dentar live --record`): capture times, haptic
//    steps and the poses as 3x4 row-major numbers (full precision), read back
//    by parse_recording_table (recording_table.h) when the recording is
//    replayed;
//  - the offline run's (`dentar offline`): poses in mm and quaternions,
//    errors against the footage's truth, and every stage time.
// A pose cell is empty while its body is lost.
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/tracker.h"
#include "dentar/training/mirror_use.h"
#include "dentar/volume/material.h"
#include "dentar/volume/result.h"

namespace dentar::session {

// The states a tracked body is in (ar::TrackState: tracking, predicted, lost).
using TrackState = ar::TrackState;

// "tracking", "predicted" or "lost"; FrameRecord keeps a state as its int
// (0, 1, 2): anything else is "lost".
const char* state_name(TrackState s);
const char* state_name(int s);
// The state named by `name` (one of the three names); error names the value.
Result<TrackState> parse_state(const std::string& name);

// ---- the live recording's layout ----
// stereo (issue 28): more columns at the end: eyes (both, left, right), then the right eye's
// own composite (session 17; FrameRecord::right): right_composited (0/1: the headset's view
// composited it), right_overlay, right_mirror_drawn (0/1), right_composite_ms; without
// stereo the layout is the mono one, byte for byte.
std::string recording_csv_header(bool stereo = false);  // with its newline
// One row: `index` the recording's frame number, `steady_s` the capture
// clock, `source_index` the camera's frame number (ar::Frame::index: its frames dropped
// counted; a live: stand-in's frame in its file).
std::string recording_csv_row(const ar::FrameRecord& r, std::int64_t index, double steady_s,
                              std::int64_t source_index, bool stereo = false);

// ---- the offline run's layout ----
struct OfflineFrameRow {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  int frame = 0;
  double time_s = 0;
  int man_state = 2, mir_state = 2;
  Eigen::Isometry3d T_cam_man = Eigen::Isometry3d::Identity(), T_cam_mtag = Eigen::Isometry3d::Identity();
  double man_rms_px = kNaN;
  int man_tags = 0, mir_tags = 0, tags_detected = 0;
  bool full_frame = true;
  std::uint64_t haptic_step = 0;
  bool pedal = false, overlay = false, mirror_drawn = false;
  double removed_mm3[volume::kNumMaterials] = {};
  double man_err_mm = kNaN, man_err_deg = kNaN, tooth_err_px = kNaN, tip_err_mm = kNaN, iou = kNaN;
  // Mirror plane pose (T_cam_mir = T_cam_mtag T_mtag_mir, the frame the
  // reflection is drawn from) against truth: centre distance and rotation.
  double mir_err_mm = kNaN, mir_err_deg = kNaN;
  double read_ms = 0, detect_ms = 0, pose_ms = 0, filter_ms = 0, track_ms = 0, haptics_ms = 0, mesh_ms = 0,
         composite_ms = 0, write_ms = 0, latency_ms = 0;
  std::size_t triangles = 0;
  // Stereo runs (issue 28): the eyes that had an image (ar::FrameRecord::eyes) and the eyes in
  // the mannequin's and the mirror's fits. Written only when the run is stereo.
  int eyes = 0, man_views = 0, mir_views = 0;
  // The right eye's own composite (--eye both, session 17): drawn, its overlay and mirror, its
  // time (ms; NaN: not composited), its tooth against its truth (box corners, px) and its
  // silhouette IoU (NaN: no truth or mask).
  bool right_composited = false, right_overlay = false, right_mirror_drawn = false;
  double right_composite_ms = kNaN, right_tooth_err_px = kNaN, right_iou = kNaN;
};
// stereo: more columns at the end: eyes (both, left, right: the single-view path),
// man_views, mirror_views, then the right eye's (session 17): right_composited, right_overlay,
// right_mirror_drawn (0/1), right_composite_ms, right_tooth_err_px, right_silhouette_iou
// (empty: none); without stereo the layout is the mono one, byte for byte.
std::string offline_csv_header(bool stereo = false);  // with its newline
std::string offline_csv_row(const OfflineFrameRow& r, bool stereo = false);
// "both", "left", "right" (ar::FrameRecord::eyes), "" for mono (0).
const char* eyes_name(int eyes);

// ---- reading either layout back (mirror use, training/mirror_use.h) ----
// The camera frames of a frames.csv of `dentar offline` (man_tx_mm.., man_qw..; haptic_step)
// or of `dentar live --record` (man_T, mirror_T: 12 numbers; haptic_steps): poses as drawn
// (tracking or predicted), session time = haptic steps / rate_hz, pedal. A row cut short (a
// crash) ends the table. Errors name the file, line and column.
Result<std::vector<training::ViewFrame>> read_view_frames(const std::string& path, double rate_hz);

}  // namespace dentar::session
