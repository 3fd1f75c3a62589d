// The live calibration steps' bookkeeping, without any window or device: poses and touches go
// in as they arrive, live figures come out, and each step knows when it is done. Used by
// `dentar calibrate live` (live/calibrate_app.h); tested on its own.
// Frames: T_dev_sty from the device; tips in `dev`; targets in the frame the step names.
// Units: metres, radians, seconds.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "dentar/calibration/camera_model.h"
#include "dentar/calibration/intrinsics.h"
#include "dentar/calibration/pivot.h"
#include "dentar/calibration/registration.h"
#include "dentar/calibration/touch.h"

namespace dentar::calibration {

struct LivePivotOptions {
  // A pose is kept when the stylus turned at least this much since the last kept pose (holding
  // still adds nothing: the same pose many times would only fake precision).
  double min_turn_rad = 1.5 * 3.14159265358979 / 180;
  // The step stops itself when the tip is known to this (1 sigma, sqrt of the covariance's
  // trace) and the gates of `gates` pass.
  double target_tip_sd_m = 0.2e-3;
  int max_poses = 400;
  PivotOptions gates;
  std::string validate() const;
};

class LivePivot {
 public:
  explicit LivePivot(const LivePivotOptions& options = {});
  // A stylus pose from the device; returns true when it was kept (and the figures updated).
  bool add(const Eigen::Isometry3d& T_dev_sty);
  int poses() const { return static_cast<int>(poses_.size()); }
  // Figures of the poses so far (gates relaxed, so they show from 3 poses on).
  const PivotSummary& current() const { return current_; }
  double tip_sd_m() const;  // predicted tip error, 1 sigma; infinity before 3 poses
  bool done() const;        // gates pass and tip_sd_m() <= target
  PivotSummary final_result() const;  // with the real gates
  // What the instructor should do now ("rock further in all directions: 9.0 of 15 deg").
  std::string hint() const;
  const LivePivotOptions& options() const { return options_; }

 private:
  LivePivotOptions options_;
  std::vector<Eigen::Isometry3d> poses_;
  PivotSummary current_;
};

// Points touched in a guided order (divots on the mannequin, landmarks on the tooth, the mirror
// rim): the tip's positions stream in; a key or pedal press takes the touch of the next
// target, refused when the tip moved (TouchDetector) or is nowhere near any plausible place.
class LiveTouches {
 public:
  LiveTouches(std::string what, int count, const TouchOptions& touch = {});
  void add_sample(double t_s, const Eigen::Vector3d& tip_dev);
  // Takes the touch of target next(): ok advances to the next target; refused keeps it.
  TouchResult take();
  int next() const { return static_cast<int>(taken_.size()); }
  int count() const { return count_; }
  bool done() const { return next() >= count_; }
  int refused() const { return refused_; }
  const std::vector<Eigen::Vector3d>& taken_dev() const { return taken_; }
  bool still() const { return detector_.still(); }
  const std::string& last_message() const { return last_message_; }

 private:
  std::string what_;
  int count_;
  TouchDetector detector_;
  std::vector<Eigen::Vector3d> taken_;
  int refused_ = 0;
  std::string last_message_;
};

// Running fit of the touches so far against their known positions (>= 4 points): FRE and the
// TRE predicted at `target` (a point in the known positions' frame). Gates are relaxed (shown,
// not enforced) so the instructor sees the figures after every touch.
RegistrationSummary running_fit(const std::vector<Eigen::Vector3d>& touched,
                                const std::vector<Eigen::Vector3d>& known, const Eigen::Vector3d& target);

// ---- the live camera step ------------------------------------------------------------------
// Board views taken from a live video: every frame's detection streams in; a key or pedal
// press takes the latest view, refused with the reason when the board is not found, moved
// during the last still_window_s, is blurred (focus measure well below the views taken so far),
// does not lie where the board spec puts its points (the wrong board), or is too similar to a
// view already taken. The running calibration (the 5-coefficient fit, as `dentar calibrate
// camera` prints it) gives RMS and the 1-sigma of fx fy cx cy after each accepted view; the
// trust map of the model selection (camera_model.h, computed by the caller, it takes seconds)
// drives the suggestion of where a view is needed next and the step's own stop.
struct LiveCameraOptions {
  IntrinsicsOptions intrinsics;  // min_views, the coverage grid, the tooth region
  int target_views = 12;         // the step stops itself from here on, once the image is trusted
  int max_views = 30;            // ... and at the latest here
  double still_window_s = 0.4;   // the board must have been seen still this long
  double max_speed_px_per_s = 8; // mean corner speed still counted as still
  // Too similar: the points moved less than this x the image diagonal (mean) from a taken view
  // (20 px at 640x480; the same place with another tilt moves them 25-40 px and is useful).
  double min_new_fraction = 0.025;
  double min_sharpness_ratio = 0.5;  // focus measure vs the median of the taken views
  // Wrong board: RMS distance of the points from the best homography of the spec's layout,
  // above max(max_layout_px, max_layout_fraction x the board's image diagonal).
  double max_layout_px = 6, max_layout_fraction = 0.03;
  // Stop by itself: target_views reached and the trust map (for the views taken) covers this
  // fraction of the image and all of the tooth region.
  double done_trusted_fraction = 0.9;
  std::string validate() const;
};

struct CameraTake {
  bool ok = false;
  std::string message;  // taken: "view 7 taken (54 points)"; refused: the reason and what to do
};

class LiveCameraViews {
 public:
  LiveCameraViews(int width, int height, const LiveCameraOptions& options = {});
  // A frame at time t_s: the board view when found (empty points otherwise, with `reason`),
  // and a focus measure of the image over the board (any scale; compared between frames).
  void add_frame(double t_s, const BoardView* view, const std::string& reason, double sharpness);
  CameraTake take();  // the latest frame's view
  // Live state for the HUD.
  bool board_seen() const { return last_found_; }
  bool still() const;              // seen, and still for still_window_s
  double still_for_s() const;      // how long the board has been seen still (0: moving / not seen)
  const std::string& status() const { return status_; }  // what the latest frame says
  const BoardView& last_view() const { return last_view_; }
  bool last_layout_ok() const { return last_layout_ok_; }
  int views() const { return static_cast<int>(views_.size()); }
  int refused() const { return refused_; }
  const std::vector<BoardView>& taken() const { return views_; }
  const IntrinsicsSummary& running() const { return running_; }  // ok once min_views are taken
  CoverageMap coverage() const;  // board points of the taken views on the options' grid
  // The trust map computed (by the caller) for the first `views` views.
  void set_trust(const TrustMap& trust, int views);
  const TrustMap& trust() const { return trust_; }
  int trust_views() const { return trust_views_; }
  // Where a view is needed next: a cell (col, row) of the grid, and the words for it; false
  // when coverage and trust are sufficient.
  bool suggestion(int& col, int& row, std::string& text) const;
  bool done() const;
  const LiveCameraOptions& options() const { return options_; }

 private:
  struct Seen {
    double t_s;
    std::vector<Eigen::Vector2d> px;
    std::vector<Eigen::Vector3d> obj;
  };
  double speed(const Seen& a, const Seen& b) const;  // mean corner speed between two frames, px/s
  LiveCameraOptions options_;
  int width_, height_;
  std::vector<Seen> recent_;  // detections within the last still window (and one before)
  BoardView last_view_;
  double last_t_ = 0, last_sharpness_ = 0, still_since_ = -1;
  bool last_found_ = false, last_layout_ok_ = true;
  std::string status_ = "waiting for the camera";
  std::vector<BoardView> views_;
  std::vector<double> sharpness_;
  int refused_ = 0;
  IntrinsicsSummary running_;
  TrustMap trust_;
  int trust_views_ = 0;
};

}  // namespace dentar::calibration
