// The live calibration steps' bookkeeping, without any window or device: poses and touches go
// in as they arrive, live figures come out, and each step knows when it is done. Used by
// `dentar calibrate live` (live/calibrate_app.h); tested on its own.
// Frames: T_dev_sty from the device; tips in `dev`; targets in the frame the step names.
// Units: metres, radians, seconds.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

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

}  // namespace dentar::calibration
