// FramePipeline: one camera frame through the trainer. The same object
// serves `dentar offline` (recorded footage, simulated time) and
// `dentar live` (a camera, real time); both are thin drivers around it.
//
//   frame + capture time + latest haptic snapshot
//     -> tracker (mannequin, mirror, pen)              tracking
//     -> T_cam_tooth = T_cam_man * T_man_tooth          registration
//     -> ToothMeshes::sync (inline re-mesh, or the      cutting-mesh update
//        mesher thread's meshes swapped in)
//     -> Compositor (video + tooth + bur + mirror        compositing, occlusion
//        reflection, phantoms, foreground)
//   -> composite image + FrameRecord (what happened, with stage times)
//
// Determinism: with the same frames, capture times, snapshots and an inline
// mesher, process() gives the same records and composites (tested).
// Thread/context: create() and process() on one thread, with a GLES 3
// context current (egl_context.h); destroy the pipeline before the context.
// With PipelineOptions::eye_threads = 2 (stereo) the pipeline owns one worker
// thread with a headless context of its own for the right eye (joined by the
// destructor); process() returns only when both eyes are done.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <string>
#include <thread>
#include <vector>

#include "dentar/ar/compositor.h"
#include "dentar/ar/note_label.h"
#include "dentar/ar/station_scene.h"
#include "dentar/ar/stereo_tracker.h"
#include "dentar/ar/tracker.h"
#include "dentar/haptics/engine.h"
#include "dentar/volume/result.h"
#include "dentar/volume/surface.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::ar {

// Issue 27: in a training mode (the haptic snapshot's mode != 0) the expert's tool is drawn
// as a second, translucent handpiece at the snapshot's T_tooth_expert_tip, in the direct view
// and in the mirror (compositor.h, ExpertTool). In mode 5 (hints), while the recording
// drills (snapshot.expert_drilling), the tool and the tooth change colour.
struct ExpertStyle {
  bool draw = true;
  double opacity = 0.45;                                    // (0, 1]
  Eigen::Vector3f tint{0.55f, 0.80f, 1.30f};                // cool blue (sRGB multipliers, 0..2)
  Eigen::Vector3f drilling_tint{1.45f, 0.80f, 0.30f};       // mode 5 while the expert drills: orange
  Eigen::Vector3f tooth_drilling_tint{1.15f, 0.92f, 0.70f};  // and the tooth warms
  bool depth_tested = false;  // ExpertTool::depth_tested: false = overlaid (a hint is never hidden)
  std::string validate() const;                             // empty, or names the field
};

struct PipelineOptions {
  TrackerOptions tracker;
  CompositorOptions compositor;
  ExpertStyle expert;
  // Poses are predicted to capture time + this (video see-through shows the
  // captured frame itself, so 0 is right unless the display adds delay), s.
  double predict_s = 0.0;
  // Issue 28: track from both eyes of the station's stereo rig (StereoTracker; the station
  // must carry "stereo"). Frames then give FrameInput::right_image; poses are in the rig
  // frame (= the left eye's) and the composite is the left eye's image; the right eye's is
  // composited too when process() is given a right output (FramePipeline::process).
  bool stereo = false;
  // Issue 28 (session 17): stereo only. 2 = the right eye's tag tracking and its own composite
  // run on a worker thread of the pipeline (with its own GL context), beside the left eye's
  // on the caller's thread; 1 = both on the caller's thread, one after the other. The two
  // give the same records and pixels (each eye has its own tracker and compositor; tested).
  // Ignored without stereo.
  int eye_threads = 1;
  // Called once on the worker thread before its GL context is made (CPU affinity: llvmpipe's
  // rasteriser threads inherit the mask); may be empty.
  // When the worker's headless context cannot be made (session 18), create() does not fail: the
  // pipeline runs both eyes on the caller's thread, options().eye_threads becomes 1 and
  // FramePipeline::eye_thread_note() says why. Test hook: the environment variable
  // DENTAR_TEST_FAIL_EYE_CONTEXT=1 refuses the worker's context.
  std::function<void()> eye_thread_init;
  std::string validate() const;  // empty, or names the field
};

// The tooth's meshes as the compositor draws them. Inline (offline, tests):
// sync() re-meshes the volume's dirty chunks on the calling thread, so every
// frame shows every cut made before it. Threaded (live): a mesher thread
// re-meshes at its own pace into its own Surface and publishes changed
// chunks; sync() adopts the published chunks (a short lock, never on the
// haptic thread). The volume is not owned and must outlive this object; it
// may be cut concurrently only through volume::Cutter.
class ToothMeshes {
 public:
  explicit ToothMeshes(const volume::VoxelVolume& volume);  // extracts the whole surface
  ~ToothMeshes();                                           // stops the mesher
  ToothMeshes(const ToothMeshes&) = delete;
  ToothMeshes& operator=(const ToothMeshes&) = delete;

  // Starts the mesher thread (period between passes, s); `init` runs once on
  // it first (CPU affinity; may be empty). Idempotent.
  void start_mesher(double period_s = 1.0 / 120.0, std::function<void()> init = {});
  void stop_mesher();
  bool threaded() const { return mesher_.joinable(); }
  // Frame thread: brings display() up to date; returns the chunks changed.
  int sync();
  const volume::Surface& display() const { return display_; }

  struct Stats {
    std::uint64_t passes = 0, chunks = 0;  // mesher passes, chunks re-meshed
    double max_pass_ms = 0;
  };
  Stats stats() const;

 private:
  void mesher_main(double period_s);

  const volume::VoxelVolume* volume_;
  volume::Surface display_;                 // frame thread
  std::unique_ptr<volume::Surface> back_;   // mesher thread (threaded mode)
  mutable std::mutex mutex_;                // guards pending_ and stats_
  std::vector<std::pair<int, volume::ChunkMesh>> pending_;
  Stats stats_;
  std::atomic<bool> stop_{false};
  std::thread mesher_;
};

struct FrameInput {
  // CV_8UC3 BGR, or the camera's own YUYV (CV_8UC2, issue 28: tracked from its luma and
  // converted only by the compositor), the station camera's size, as captured.
  const cv::Mat* image = nullptr;
  // Stereo (PipelineOptions::stereo): `image` is the left eye, this the right eye (the rig's
  // camera_right size). An eye lost this frame is null or empty (StereoSource's single-eye
  // frames): the bodies are fitted to the other eye alone, and with the left eye lost the
  // composite is drawn on the right eye's image (FrameRecord::eyes). Ignored without stereo.
  const cv::Mat* right_image = nullptr;
  std::int64_t index = 0;
  double capture_time_s = 0;  // monotonic, s
  // The latest haptic state (null: no engine, no bur). The bur is drawn when
  // stylus_valid, at snapshot.T_dev_sty through the station calibration.
  const haptics::HapticSnapshot* haptic = nullptr;
  bool stylus_valid = false;
  // Replaying a live run whose discovery ran off the frame path
  // (TrackerOptions::discovery = kScheduled): what the live run did at this
  // frame. Null otherwise.
  const DiscoveryCue* discovery = nullptr;
  // The live display's GPU path (compositor.h, compose_gl): the composite
  // goes into these textures and stays on the GPU (out.image empty).
  // Zero textures = the CPU composite (offline, tests, fallback).
  GlFrameTarget gl_target;
  // Issue 27: a lesson's note active now (null or empty: none). Drawn beside the tooth
  // (note_label.h) when the tooth is drawn (mannequin tracking or predicted); into the CPU
  // composite only (the GPU path's window draws rec.note_anchor_px's layout itself).
  const std::string* note = nullptr;
  // Issue 28 session 20: the CPU composites of a YUYV video stay YUYV outside the overlay
  // (CompositeInput::keep_yuyv: out.image is the camera's frame, out.patch the composite
  // inside out.patch_rect), for a consumer that converts on its own upload (the live
  // window). Not with a note on show (its label is drawn into a BGR composite).
  bool keep_yuyv = false;
};

// One eye's composite as FramePipeline::process drew it (issue 28, session 16: the right
// eye's; FrameRecord keeps the main composite's in its own fields, as before).
struct EyeRecord {
  bool composited = false;  // this eye was composited this frame
  bool overlay = false, mirror_drawn = false, expert_drawn = false;
  bool note_anchored = false, note_drawn = false;
  Eigen::Vector2d note_anchor_px = Eigen::Vector2d::Zero();  // the tooth's centre in this eye's image, px
  double composite_ms = 0;
  std::size_t triangles = 0;
  cv::Rect region;  // CompositeResult::region: the pixels the overlay touched
  std::int64_t readback_px = 0, cpu_blend_px = 0;
};

// What happened to one frame. States: 0 tracking, 1 predicted, 2 lost.
struct FrameRecord {
  std::int64_t frame = 0;
  double time_s = 0;  // capture time
  int man_state = 2, mir_state = 2, pen_state = 2;
  Eigen::Isometry3d T_cam_man = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam_mtag = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam_ptag = Eigen::Isometry3d::Identity();
  double man_rms_px = 0;  // NaN when not measured
  int man_tags = 0, mir_tags = 0, pen_tags = 0, tags_detected = 0;
  bool full_frame = false;
  // Discovery off the frame path (tracker.h): a full-frame search was started
  // on this frame's image; the one started on frame disc_merged (-1 none)
  // was merged, taking disc_ms on its own thread.
  bool disc_start = false;
  std::int64_t disc_merged = -1;
  double disc_ms = 0;
  // Haptics as drawn.
  std::uint64_t haptic_step = 0;        // HapticSnapshot::step
  std::uint64_t haptic_steps_done = 0;  // HapticSnapshot::steps_done (replay: step the engine to this)
  bool pedal = false, stylus_drawn = false;
  double force_N = 0;
  double removed_mm3[8] = {};
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
  // The drawn stylus pose's place in the engine's steps (haptics::PoseHistory::Sample::index,
  // fractional) when the driver drew the pose of the frame's exposure (dentar live's latency
  // compensation, issue 24); -1: the snapshot's newest pose. Set by the driver, not process().
  double pose_step = -1;
  // Stage times, ms.
  double track_ms = 0, detect_ms = 0, pose_ms = 0, filter_ms = 0, mesh_ms = 0, composite_ms = 0;
  int mesh_chunks = 0;
  bool overlay = false, mirror_drawn = false;
  // Issue 27: the expert's tool drawn (a training mode), and mode 5's drilling colours shown.
  bool expert_drawn = false, expert_drilling_shown = false;
  // Issue 27: a note was given and the tooth drawn: note_anchor is the tooth's centre in the
  // composite (px; note_label.h); note_drawn: the label went into the CPU composite.
  bool note_anchored = false, note_drawn = false;
  Eigen::Vector2d note_anchor_px = Eigen::Vector2d::Zero();
  std::size_t triangles = 0;
  // The compositor's CPU traffic (CompositeResult): pixels read back from GL
  // and pixels blended on the CPU; both 0 when gpu_composite.
  bool gpu_composite = false;
  std::int64_t readback_px = 0, cpu_blend_px = 0;
  // Stereo (issue 28): the eyes that had an image (kEyesBoth, or one eye: the single-view
  // path), and the eyes whose corners entered the mannequin's and the mirror's fits.
  // kEyesMono (0) for one camera. Poses above are in the rig frame; with only the right eye
  // the composite is that eye's image.
  static constexpr int kEyesMono = 0, kEyesLeft = 1, kEyesRight = 2, kEyesBoth = 3;
  int eyes = kEyesMono;
  int man_views = 0, mir_views = 0;
  // Issue 28 (session 16): the right eye's own composite (process() given a right output and
  // both eyes had an image); right.composited false otherwise. Its composite_ms is not in
  // composite_ms (the main composite's).
  EyeRecord right;
};

class EyeWorker;  // frame_pipeline.cpp: the right eye's thread (PipelineOptions::eye_threads)

class FramePipeline {
 public:
  ~FramePipeline();  // the worker's GL objects go on the worker, then the worker
  // Errors name the option or the station field, or the GL failure.
  static Result<std::unique_ptr<FramePipeline>> create(const StationScene& station,
                                                       const PipelineOptions& options);
  // One frame; `out` receives the composite (out.image: BGR, camera size).
  // Errors (wrong frame size or type, tracker or GL failure) name the frame.
  //
  // Stereo, the right eye's composite (issue 28, session 16): with `right_out` given and both
  // eyes' images present, the right eye is composited too, by the same per-eye step as the
  // left (compose_eye): the right camera's intrinsics (station "stereo": camera_right), every
  // tracked pose carried into the right eye's frame (T_camr_rig = T_caml_camr^-1), the
  // occlusion mask segmented on the right image (its own adapted colour model), the mirror's
  // reflection seen from the right eye, the lesson's note beside the tooth as the right eye
  // sees it, the region path as configured. Always the CPU composite (right_out->image),
  // also when `in.gl_target` puts the left eye's on the GPU. rec.right says what was drawn.
  // Otherwise (mono, no right_out, or an eye missing: the single-view path) right_out->image
  // comes back empty: the display shows the one composite to both eyes (mono).
  Status process(const FrameInput& in, ToothMeshes& meshes, CompositeResult& out, FrameRecord& rec,
                 CompositeResult* right_out = nullptr);
  // Draws the tooth once on a grey frame (GPU uploads, levels of detail,
  // shader warm-up: ~0.5 s on llvmpipe) so the first real frame is not late,
  // then resets the tracker and the segmenter: the frames that follow are
  // processed exactly as without it. With gl_target's textures: the GPU
  // path's shaders are warmed up too, drawing into them (FrameInput::gl_target).
  Status warm_up(ToothMeshes& meshes, const GlFrameTarget& gl_target = {});

  Tracker& tracker() { return tracker_; }
  bool stereo() const { return stereo_ != nullptr; }
  Compositor& compositor() { return compositor_; }
  const StationScene& station() const { return station_; }
  const PipelineOptions& options() const { return options_; }
  // Stereo: the eye threads in use (1 or 2; options().eye_threads after any fallback), and why
  // a second one asked for is not running ("" when it is, or was not asked for).
  int eye_threads() const { return worker_ ? 2 : 1; }
  const std::string& eye_thread_note() const { return eye_thread_note_; }
  // The last processed frame's tag detections (full-image OpenCV px): for checks that look
  // at single tags (live station health: did a mannequin tag move?). Valid until the next process().
  const std::vector<DetectedTag>& last_detections() const { return last_tags_; }

 private:
  FramePipeline(StationScene st, PipelineOptions o, Tracker t, Compositor c);
  StationScene station_;
  PipelineOptions options_;
  Tracker tracker_;
  Compositor compositor_;
  std::vector<DetectedTag> last_tags_;
  // Stereo (PipelineOptions::stereo): the joint tracker, the station as the right eye sees it
  // (calibration.camera = stereo.camera_right) and that eye's compositor (made at create()).
  std::unique_ptr<StereoTracker> stereo_;
  StationScene station_right_;
  std::unique_ptr<Compositor> right_compositor_;
  // eye_threads == 2: the right eye's tracking and compositor run (and its compositor's GL
  // objects live) on this worker's thread and context.
  std::unique_ptr<EyeWorker> worker_;
  std::string eye_thread_note_;  // why eye_threads = 2 fell back to 1 ("" otherwise)
  Status track_stereo(const FrameInput& in, FrameRecord& r);
  // One eye's view: its image, compositor, station (its camera) and T_eye_rig (identity for
  // the left eye and mono; T_camr_rig for the right eye).
  struct EyeView {
    const cv::Mat* image = nullptr;
    Compositor* compositor = nullptr;
    const StationScene* station = nullptr;
    Eigen::Isometry3d T_eye_rig = Eigen::Isometry3d::Identity();
    GlFrameTarget gl_target;  // zero textures: the CPU composite
  };
  // The per-eye step both eyes run: the rig-frame poses of `rig` carried into the eye, the
  // composite, the note label. `rig` holds everything but the video and the eye's poses.
  Status compose_eye(const EyeView& eye, const CompositeInput& rig, const FrameInput& in, ToothMeshes& meshes,
                     CompositeResult& out, EyeRecord& er);
};

// Column-major 4x4 (HapticSnapshot) to an isometry.
Eigen::Isometry3d isometry_from_colmajor(const double* m);

}  // namespace dentar::ar
