#include "dentar/calibration/touch.h"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace dentar::calibration {

std::string TouchOptions::validate() const {
  if (!(window_s > 0 && window_s <= 10)) return "touch window_s must be in (0, 10] s";
  if (!(still_m > 0 && still_m <= 0.01)) return "touch still_m must be in (0, 10] mm";
  if (!(max_gap_s > 0)) return "touch max_gap_s must be > 0";
  if (min_samples < 2) return "touch min_samples must be >= 2";
  return {};
}

TouchDetector::TouchDetector(const TouchOptions& options) : options_(options) {}

void TouchDetector::add(double t_s, const Eigen::Vector3d& tip) {
  if (!tip.allFinite() || !std::isfinite(t_s)) {  // a lost pose breaks the touch
    samples_.clear();
    return;
  }
  if (!samples_.empty() && (t_s - samples_.back().t_s > options_.max_gap_s || t_s < samples_.back().t_s))
    samples_.clear();
  samples_.push_back({t_s, tip});
  // Keep one sample at or before the window's start so the span can reach window_s.
  while (samples_.size() > 2 && samples_.back().t_s - samples_[1].t_s >= options_.window_s)
    samples_.pop_front();
}

TouchResult TouchDetector::evaluate() const {
  TouchResult r;
  r.samples = static_cast<int>(samples_.size());
  if (samples_.empty()) return r;
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (const auto& s : samples_) m += s.p;
  m /= static_cast<double>(samples_.size());
  double travel = 0;
  for (const auto& s : samples_) travel = std::max(travel, (s.p - m).norm());
  r.tip = m;
  r.travel_m = travel;
  return r;
}

bool TouchDetector::still() const {
  if (static_cast<int>(samples_.size()) < options_.min_samples) return false;
  if (samples_.back().t_s - samples_.front().t_s < options_.window_s * 0.999) return false;
  return evaluate().travel_m <= options_.still_m;
}

TouchResult TouchDetector::take(const std::string& what) const {
  TouchResult r = evaluate();
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  const double span = samples_.empty() ? 0 : samples_.back().t_s - samples_.front().t_s;
  if (static_cast<int>(samples_.size()) < options_.min_samples || span < options_.window_s * 0.999) {
    os << what << ": touch refused: the stylus was seen for only " << span << " s (needs "
       << options_.window_s << " s held still); hold the tip on the point and touch again";
    r.message = os.str();
    return r;
  }
  if (r.travel_m > options_.still_m) {
    os << what << ": touch refused: the stylus moved by " << r.travel_m * 1e3
       << " mm during the touch (limit " << options_.still_m * 1e3
       << " mm); hold the tip still in the point and touch again";
    r.message = os.str();
    return r;
  }
  r.ok = true;
  return r;
}

}  // namespace dentar::calibration
