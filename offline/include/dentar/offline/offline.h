// The offline run for testers (`dentar offline`): recorded footage through
// the whole trainer pipeline, frame by frame, in simulated time:
//
//   frame source ─▶ tracker (mannequin, mirror) ─┐
//   session log ─▶ ReplayDevice ─▶ haptic engine ─┼─▶ mesher ─▶ compositor ─▶ video
//                  (1 kHz, stepped to the frame's  │
//                   capture time)                  └─▶ per-frame CSV, summary JSON, HTML report
//
// Time: frame k's capture time is its container timestamp (k/fps for the
// generator's footage); haptic step n is at n / rate_hz. Before compositing
// frame k the engine has run every step not after its capture time, exactly
// as the generator did when it rendered the frame, so cuts and video agree.
//
// Outputs in out_dir (docs/formats.md, "Offline run"):
//   composite.mkv   the composited video (Motion JPEG by default, or FFV1)
//   frames.csv      one row per frame: poses, states, errors against truth,
//                   stage times, capture-to-composite latency
//   summary.json    totals, percentiles, goals; "complete": true
//   report.html     plots (inline SVG) and tables for testers
//   stills/         a few composited frames as PNG (shown in the report)
// A run that fails writes FAILED.txt (the reason) and no summary.json or
// report.html, and removes those left from an earlier run, so nothing
// half-written looks complete. The CSV and video are renamed into place only
// at the end.
//
// Thread/context: run_offline creates its own headless EGL context; call it
// from a thread without a current context.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dentar/ar/compositor.h"
#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/synth.h"
#include "dentar/ar/tracker.h"
#include "dentar/volume/result.h"

namespace dentar::offline {

struct OfflineSummary;

struct OfflineOptions {
  // Footage: a video file or an image folder (frame_source.h). Empty: the
  // built-in footage is generated first into out_dir/footage with the
  // generator (preset, frames, size below) and the run uses its station,
  // session log and ground truth.
  std::string footage;
  std::string station;  // station JSON; required with footage
  // Stereo footage (issue 28) of the station's rig ("stereo" in the station file):
  //  - stereo: track from both eyes (ar::StereoTracker through FramePipeline); `footage` is
  //    side by side (left | right, `dentar synth --stereo`), or the left eye when
  //    footage_right names the right eye's file (two recordings paired by frame time). An eye
  //    whose recording ends first leaves the other's frames alone (the single-view path),
  //    logged in frames.csv's `eyes` column. Poses and errors are in the rig frame (the left
  //    eye's truth.jsonl), the composite is the left eye's (the right eye's while the left
  //    is missing).
  //  - eye "left" or "right" (stereo false): one eye of side-by-side footage through the mono
  //    path, against that eye's truth (truth.jsonl / truth_right.jsonl, masks / masks_right):
  //    the mono anchor on the same frames.
  //  - eye "both" (with stereo; issue 28, session 16): each eye composited (FramePipeline's
  //    right output): composite.mkv the left eye's, composite_right.mkv the right eye's, frame
  //    for frame (docs/formats.md "Offline run"); summary.json "right_eye" gives the right
  //    eye's tooth against truth_right.jsonl / masks_right beside the footage.
  bool stereo = false;
  std::string footage_right;
  std::string eye;
  std::string session;  // session log (.dlog); empty = no drilling (uncut tooth, no bur)
  // Ground truth (truth.jsonl, generator format) and masks folder; empty =
  // looked for beside the footage ("auto"); "none" = ignore.
  std::string truth, masks;
  std::string out_dir;

  // Built-in footage (used only when footage is empty).
  ar::SynthPreset preset = ar::SynthPreset::kStandard;
  int builtin_frames = 90;
  int builtin_width = 1280, builtin_height = 720;
  std::uint64_t seed = 1;

  ar::TrackerOptions tracker;
  // Replaying a `dentar live --record` folder: its recording.json says how
  // the live run tracked (camera_response, mirror_rim), and the replay does
  // the same unless these say the caller chose tracker.detector.response /
  // tracker.mirror_rim_refine itself (then a difference is a warning: the
  // poses will not be the live run's).
  bool camera_response_given = false;
  bool mirror_rim_given = false;
  bool stereo_mirror_rim_given = false;  // tracker.stereo_mirror_rim chosen by the caller (--stereo-mirror-rim)
  ar::CompositorOptions compositor;
  // A session trained in a mode (`dentar lesson run`): the expert's tool as a second,
  // translucent handpiece (frame_pipeline.h, ExpertStyle; draw = false: not drawn).
  ar::ExpertStyle expert;
  // Poses are predicted to capture time + this (video see-through shows the
  // captured frame itself, so 0 is right unless the display adds delay), s.
  double predict_s = 0.0;
  bool predict_given = false;  // a live recording replays with its own predict_ms unless this is set
  bool scale_calib = false;  // accept footage of another size with the same aspect ratio
  int max_frames = 0;        // 0 = all
  bool write_video = true;
  // Codec of composite.mkv: "mjpg" (Motion JPEG, quality 95: ~10x faster to
  // encode than FFV1 at 720p, plays everywhere) or "ffv1" (lossless, slow).
  std::string video_codec = "mjpg";
  int stills = 4;  // composited frames saved as PNG for the report
  // Called once at the end of a successful run, after frames.csv is in place
  // and before summary.json and report.html are written. Returns HTML shown
  // in the report under "Session score"; may add warnings to the summary.
  // The drivers (tools/) score the session here; ar does not know training.
  std::function<std::string(OfflineSummary&)> after_run;
  std::string validate() const;
};

// Percentiles of one per-frame quantity.
struct Stat {
  double median = 0, p95 = 0, p99 = 0, max = 0, mean = 0;
  int n = 0;  // frames that had the quantity
};

struct OfflineSummary {
  int frames = 0;
  double footage_s = 0;  // duration covered
  int tracking = 0, predicted = 0, lost = 0;  // mannequin states, frames
  int mirror_tracking = 0;
  int overlays = 0;  // frames with the tooth drawn
  // Issue 27, a session trained in a mode: frames with the expert's tool drawn, and those
  // with mode 5's drilling colours.
  int expert_frames = 0, expert_drilling_frames = 0;
  // Frames with a lesson's note drawn beside the tooth (the lesson's lesson.json beside the
  // expert's recording; frame_pipeline.h, FrameInput::note).
  int note_frames = 0;
  bool has_truth = false;
  // Against truth (when present), tracked (tracking/predicted) frames only:
  Stat man_err_mm, man_err_deg;  // mannequin pose: translation, rotation
  Stat tooth_err_px;             // registration: projected tooth points, tracked vs true pose
  Stat tip_err_mm;               // drawn bur tip vs the true tip (co-location)
  Stat silhouette_iou;           // drawn tooth vs true visible tooth (mask == 64), masks present
  // Mirror plane pose (`mir`, T_cam_mtag T_mtag_mir) against truth, frames
  // where the mirror is tracked or predicted: centre distance, rotation.
  Stat mir_err_mm, mir_err_deg;
  // Stage times (ms) and capture-to-composite latency (ms).
  // Latency: from the decoded frame being in memory (a live camera's
  // delivery) to the composited image being ready; decode is read_ms.
  Stat read_ms, track_ms, haptics_ms, mesh_ms, composite_ms, write_ms, latency_ms;
  std::uint64_t haptic_steps = 0;
  std::uint64_t volume_hash = 0;
  std::vector<double> removed_mm3;  // per material label (volume::Material)
  bool pulp_exposed = false;
  double pulp_exposed_at_s = 0;
  double wall_s = 0;
  std::vector<std::string> warnings;
  std::string out_dir;
  std::string session, station;  // the session log replayed (empty: none) and the station file, as resolved
  // Stereo runs (OfflineOptions::stereo): frames by the eyes that had an image, frames whose
  // mannequin fit used both eyes, and the source's pairing line (StereoCaptureStats::summary).
  bool stereo = false;
  int eyes_both = 0, eyes_left = 0, eyes_right = 0, man_two_views = 0;
  std::string stereo_capture;
  // eye "both": frames with the right eye's own composite, of which with the tooth drawn;
  // the right eye's projected tooth box against truth_right (px) and silhouette IoU.
  bool both_eyes = false;
  int right_composited = 0, right_overlays = 0;
  Stat right_tooth_err_px, right_silhouette_iou;
};

// The stereo inputs of `options` (stereo, footage_right, eye) against the station and the
// footage, before any work: the station has a rig, side-by-side frames have an even width and
// hold two eyes of the station camera's size, two recordings have one size and rate. Empty
// when fine (or not stereo), else the message (bad input: `dentar offline` exits 2).
std::string check_stereo_inputs(const OfflineOptions& options);

// Runs the whole job. `progress(phase, done, total)` (may be empty; phase
// "footage" while the built-in footage is generated, then "pipeline"; total =
// -1 when unknown) is called after each frame. Errors name the input file, field or
// value and what to do (e.g. footage shorter than the session log, a station
// for another camera size, an empty video).
Result<OfflineSummary> run_offline(const OfflineOptions& options,
                                   const std::function<void(const std::string&, int, int)>& progress = {});

}  // namespace dentar::offline
