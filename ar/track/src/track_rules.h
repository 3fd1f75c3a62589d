// The rules one tracked body's state follows from frame to frame, shared by Tracker (one
// camera) and StereoTracker (both eyes): a measurement restarts or updates the filter; without
// one the body is drawn predicted while the prediction can still be trusted, else it is lost.
// `Body` has: filter (PoseFilter), state, meas_in_track, has_measurement, last_meas,
// last_meas_time_s, static_in_world.
#pragma once

#include <Eigen/Geometry>

#include "dentar/ar/tracker.h"

namespace dentar::ar::track_rules {

// The bundle fit's options for one body: the blur model
// (BundlePoseOptions::blur_stretch_sigma_px, issue 28 session 17) fits the
// mannequin's many tags only; the mirror's and the pen's few small tags keep
// each corner alone (three more parameters per eye would be most of what
// one or two tags measure).
inline BundlePoseOptions pose_options_for(const TrackerOptions& o, bool mannequin) {
  BundlePoseOptions p = o.pose;
  if (!mannequin) p.blur_stretch_sigma_px = 0;
  return p;
}

template <class Body>
void accept_measurement(Body& b, const Eigen::Isometry3d& T_cam_body_measured, double capture_s) {
  if (b.state == TrackState::kLost) {  // no velocity from a stale track
    b.filter.reset();
    b.meas_in_track = 0;
  }
  b.filter.update(T_cam_body_measured, capture_s);
  ++b.meas_in_track;
  b.has_measurement = true;
  b.last_meas = T_cam_body_measured;
  b.last_meas_time_s = capture_s;
  b.state = TrackState::kTracking;
}

// No measurement this frame: predicted, or lost (filter reset). `image_agrees()` is asked
// last (it costs an image comparison): does the image still move as the prediction says?
template <class Body, class ImageCheck>
void predict_or_lose(Body& b, const TrackerOptions& o, double capture_s, ImageCheck&& image_agrees) {
  const double age = capture_s - b.last_meas_time_s;
  double drift = 0;  // how far the prediction may be off by now, m
  if (o.filter_enabled && b.filter.initialised())
    drift = (b.filter.linear_velocity().norm() + 0.1 * b.filter.angular_velocity().norm()) * age;
  const bool drift_ok = o.max_prediction_drift_m <= 0 || drift <= o.max_prediction_drift_m;
  // A hand-held body found by one measurement has no velocity yet: the drift bound above
  // would read 0 while the hand moves it.
  const bool velocity_known =
      b.meas_in_track >= (b.static_in_world ? o.mannequin_measurements_to_predict : o.hand_held_measurements_to_predict);
  if (b.has_measurement && age <= o.stale_limit_s && drift_ok && velocity_known && image_agrees()) {
    b.state = TrackState::kPredicted;
  } else {
    b.state = TrackState::kLost;
    b.has_measurement = false;
    b.filter.reset();
  }
}

}  // namespace dentar::ar::track_rules
