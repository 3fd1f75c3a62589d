// Touches with the stylus: the tip held still on a point (a divot, a landmark, the mirror rim)
// for a moment. Used by the live calibration steps (a touch taken while the stylus moved is
// refused) and by the station health check at the start of `dentar live` (the student touches
// the health divot). Positions in any one frame, metres; times monotonic, seconds.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <string>

namespace dentar::calibration {

struct TouchOptions {
  double window_s = 0.5;     // a touch is the tip's positions over this long
  double still_m = 0.25e-3;  // largest distance of any of them from their mean
  double max_gap_s = 0.25;   // a longer gap between samples restarts the window
  int min_samples = 5;
  std::string validate() const;  // empty, or names the field
};

struct TouchResult {
  bool ok = false;
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();  // mean over the window, m
  double travel_m = 0;  // largest distance of a sample from the mean, m
  int samples = 0;
  std::string message;  // refused: why and what to do
};

// Keeps the last window_s of tip positions.
class TouchDetector {
 public:
  explicit TouchDetector(const TouchOptions& options = {});
  void add(double t_s, const Eigen::Vector3d& tip);
  void clear() { samples_.clear(); }
  // The window is full (spans window_s with min_samples) and the tip stayed within still_m.
  bool still() const;
  // Takes the touch now (the instructor pressed the key or the pedal): ok when still();
  // otherwise the message says how far the tip moved, or that the touch was too short.
  TouchResult take(const std::string& what) const;
  const TouchOptions& options() const { return options_; }

 private:
  struct Sample {
    double t_s;
    Eigen::Vector3d p;
  };
  TouchResult evaluate() const;
  TouchOptions options_;
  std::deque<Sample> samples_;
};

}  // namespace dentar::calibration
