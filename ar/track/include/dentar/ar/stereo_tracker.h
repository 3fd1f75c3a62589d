// Tracking from both eyes of a stereo head (issue 28): each rigid bundle
// (mannequin, mirror, pen) is fitted once to the tag corners seen in either
// eye, in the rig's frame (`rig` = the left eye's optical frame `cam_l`),
// with estimate_bundle_pose_views (bundle_pose.h). A frame where one eye
// sees none of a body's tags is that body's single-view fit from the other
// eye, mapped into the rig frame: the same function with one view.
//
// How it is built: one mono Tracker per eye finds the tags (its predicted
// regions, full-frame searches and second looks; tracker.h), run with its
// sigma gates off so that a body its own fit finds imprecise still has
// regions; the eye trackers' detections (TrackFrame::tags) feed the joint
// fit. The joint fit then goes through what the mono tracker does with one
// camera's fit: the RMS and position-sigma gates (TrackerOptions'
// max_rms_px, mannequin/mirror/pen_max_sigma_m, sigma_floor_px, the
// mirror's and pen's corner noise pooled with the mannequin's), the SE(3)
// filter, the tracking / predicted / lost states with the stale, drift and
// image-motion checks (on the left eye's image). The mono rim refinement
// (TrackerOptions::mirror_rim_refine) is not used here; the mirror's joint
// fit has its own (TrackerOptions::stereo_mirror_rim): the disc's rim in
// the left eye on the joint fit as the prior, then in the right eye on that
// (refine_mirror_rim, mirror_rim.h, with the covariance carried into each
// eye's frame), so the two rims fix the disc's centre in depth as well as
// across. A mirror drawn from the prediction states its error
// (TrackerOptions::mirror_prediction_sigma) and is lost once that exceeds
// the mirror's gate.
//
// Covariance: BodyTrack::covariance is the joint fit's (w rad, v m) in
// `rig` (bundle_pose.h), checked against Monte Carlo in
// bundle_pose_test.cpp (BundlePoseViews).
//
// Not thread-safe (one thread at a time, like Tracker).
#pragma once

#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>

#include "dentar/ar/station_scene.h"
#include "dentar/ar/tracker.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

struct StereoBodyTrack {
  BodyTrack track;     // poses in `rig` (T_cam_body is T_rig_body); name, state, gates as in mono
  int views_used = 0;  // eyes whose corners entered this frame's measurement (0 = not measured)
};

struct StereoTrackFrame {
  TrackFrame left, right;  // each eye's own tracker (its detections; its poses in its own eye, ungated)
  StereoBodyTrack mannequin, mirror, pen;
  double pose_ms = 0, total_ms = 0;  // the joint fits; the whole frame (both eyes)
};

class StereoTracker {
 public:
  // The station must carry a stereo rig (station.stereo); each eye's
  // images must be its camera's size. options: as Tracker's; discovery must
  // be inline. Errors name the field.
  static Result<StereoTracker> create(const StationScene& station, const TrackerOptions& options = {});
  StereoTracker(StereoTracker&&) noexcept;
  StereoTracker& operator=(StereoTracker&&) noexcept;
  ~StereoTracker();

  // One stereo pair captured together at capture_time_s (s), predicted to
  // display_time_s. An empty image is an eye lost this frame (StereoSource's
  // single-eye frames): each body is fitted to the other eye's corners alone
  // (the single-view path, poses still in `rig`); the eye's tracker starts
  // afresh when its images come back. Errors: both images empty, an eye's
  // image of the wrong size or type (the message names the eye).
  Result<StereoTrackFrame> track(const cv::Mat& left, const cv::Mat& right, double capture_time_s,
                                 double display_time_s);
  void reset();
  const TrackerOptions& options() const;
  // How track() runs the two eyes' tag trackers (issue 28, session 17): `run(left, right)`
  // must run both jobs and return once both are done, in parallel or not (the eyes' trackers
  // share no state, so the results do not depend on it). Empty (the default): one after the
  // other on the calling thread.
  using EyeRunner = std::function<void(const std::function<void()>& left, const std::function<void()>& right)>;
  void set_eye_runner(EyeRunner run);

  struct Impl;

 private:
  StereoTracker() = default;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dentar::ar
