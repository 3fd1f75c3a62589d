// Per-frame tracker of the station's rigid bodies (the mannequin's tag bundle
// and the mirror's tags): AprilTag detection -> bundle PnP -> SE(3) filter,
// with a tracking state per body.
//
// Fast path ("predicted regions"): when every body that matters has a recent
// pose, the detector does not scan the whole frame. Each body's tags are
// projected with its predicted pose; every tag's box is padded by a margin
// that grows with the tag's size, the body's image speed and the time since
// its last measurement; overlapping boxes are merged; the detector runs on
// each crop (decimation roi_decimation, full-resolution edge refinement) and
// the corners are shifted back. A full-frame search (detector.decimation)
// runs every full_frame_interval frames, whenever the mannequin is lost, and
// on the first frame; a lost mirror is searched for by those full frames
// (see `full_frame_when_any_lost`).
//
// Discovery (TrackerOptions::discovery): the full-frame search, which
// finds bodies without a usable prediction, costs ~20 ms at 1280x720. Run
// inline (kInline, the default), a frame that needs it waits for it. The
// other modes take it off the frame path: the frame's own search is the
// predicted regions only, and the frame's grey image is handed to a
// full-frame search whose tags are merged at the start of a later frame,
// as measurements at the capture time of the frame they were found in (a
// body whose newest measurement is already younger ignores them). The merged
// body is then "predicted" and its regions find it in the current frame.
// kAsync searches on a worker thread (merged at the first frame after it is
// done); kDeferred makes the same decisions but searches synchronously when
// the search is posted and merges at the next frame (deterministic: tests);
// kScheduled replays a live run's decisions (DiscoveryCue per frame), which
// makes a recording's poses reproducible bit for bit.
//
// States: kTracking = a pose was measured in this frame; kPredicted = not
// measured, but the last measurement is younger than stale_limit_s (pose =
// the filter's prediction); kLost = older or never measured: the pose is
// meaningless and the overlay must not be drawn.
//
// Frames: `cam` (OpenCV optical), `man` (mannequin), `mtag` (the mirror's tag
// frame). SI units; _ms / _px where the name says so. A Tracker is used by
// one thread at a time (it owns a libapriltag detector).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/bundle_pose.h"
#include "dentar/ar/mirror_rim.h"
#include "dentar/ar/pose_filter.h"
#include "dentar/ar/station_scene.h"
#include "dentar/ar/tag_detector.h"
#include "dentar/ar/tag_edge_fit.h"
#include "dentar/ar/tag_pattern_fit.h"
#include "dentar/calibration/station.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

enum class TrackState { kTracking, kPredicted, kLost };
enum class DiscoveryMode { kInline, kDeferred, kAsync, kScheduled };
const char* discovery_mode_name(DiscoveryMode m);  // "inline", "deferred", "async", "scheduled"
// Parses the names above; error names the value and the choices.
Result<DiscoveryMode> parse_discovery_mode(const std::string& name);

// kScheduled: what happens to discovery at one frame (from a recording).
struct DiscoveryCue {
  bool start = false;        // search this frame's image (after the merge below)
  std::int64_t merge = -1;   // merge the search started on this frame index (-1 none)
};
const char* track_state_name(TrackState s);  // "tracking", "predicted", "lost"

// TagDetectorOptions{} with response = kAuto: the tracker's default (the
// station's measured response, resolve_camera_response below), and 7 corner
// candidates per outline instead of libapriltag's 10: on every real set the
// same tags and corners as 10, and the refit's cost paid back over the real
// photos (detection 0.97x / 1.00x of plain libapriltag's instructions at
// decimation 1 / 2 instead of 1.01x / 1.04x; not on ViSP's photo at 2,
// 1.05x; 6 loses a real tag at decimation 1; docs/BENCHMARKS.md,
// "Issue 24 (session 13): detection time").
inline TagDetectorOptions auto_detector_options() {
  TagDetectorOptions d;
  d.response = CameraResponse::kAuto;
  d.corner_candidates = 7;
  return d;
}

// Resolves response == kAuto from the station's camera.response (issue 24):
// "srgb" -> kSrgb, "linear" -> kLinear, "curve" -> kCurve with its table;
// unknown -> kLinear (libapriltag's corners as they are, no linear-light
// refit). Returns a one-line note when the response is unknown, else "".
// Other responses are left as given.
std::string resolve_camera_response(TagDetectorOptions& d, const StationScene& station);

struct TrackerOptions {
  // Full-frame detection settings (families must include the station's).
  // libapriltag searches and decodes the image as delivered; the response
  // (tag_detector.h, CameraResponse) only decides the linear-light edge
  // refit. Default kAuto: the station's measured response (unknown: none).
  TagDetectorOptions detector = auto_detector_options();
  BundlePoseOptions pose;
  bool predicted_regions = true;  // the fast path above
  int full_frame_interval = 15;   // frames between full-frame searches, >= 1
  // Region padding around a tag's predicted border square: the tag's own
  // cells outside it (0.4 x side for tagStandard41h12, 0.125 for tag36h11)
  // plus roi_margin x side plus roi_min_margin_px, plus the body's predicted
  // image motion since its last measurement, times (1 + frames since it).
  double roi_margin = 0.15;
  double roi_min_margin_px = 4.0;
  // The motion padding across the image motion's direction, as a fraction
  // of the padding along it, in [0, 1]: 1 pads a square (the motion may
  // turn any way), less pads an ellipse stretched along the motion.
  double roi_motion_across = 1.0;
  // Decimation inside the regions (1 = full resolution, libapriltag's quad
  // search is then slowest but sees the smallest tags). Regions whose tags
  // are all predicted larger than roi_decimate_above_px use 2 instead (edge
  // refinement at full resolution keeps the corners as accurate).
  double roi_decimation = 1.0;
  double roi_decimate_above_px = 24.0;
  // Issue 28, measured and off by default (0): above 2, a region whose tags are all
  // predicted at least k x roi_decimate_above_px / 2 wide is searched at decimation k
  // (at most this; the decimated tag keeps the >= 12 px side that decimation 2 keeps), so the quad search's cost follows the overlay rather than the
  // camera's resolution (edge refinement stays at full resolution). docs/BENCHMARKS.md,
  // "Issue 28 session 16".
  int roi_decimation_max = 0;
  // Also search the full frame whenever the mirror (not only the mannequin)
  // is lost. Off by default: the mirror is out of view for long stretches
  // and would force the slow path on every one of those frames.
  bool full_frame_when_any_lost = false;
  // A second look in linear light (TagDetector::detect_in_linear_light),
  // with a known response (srgb or a measured curve; none with linear):
  // at the regions of the mannequin's and the pen's predicted tags the
  // search missed, and over the whole frame when a full-frame search found
  // none of the mannequin's tags or the mannequin is lost. Not for the
  // mirror's small tags (they made its ungated pose worse). The first search stays on the image as delivered
  // (real photographs, issue 24); on the generator's footage the second
  // look finds the small blurred tags the delivered image loses
  // (docs/BENCHMARKS.md issue 24 session 11: `hard` 48 -> 65 % drawn).
  // Costs only where a tag is missing (up to 2x detection on lost frames).
  bool linear_second_look = true;
  // Issue 28 session 21 (off by default): the model-based edge fit. For each of the
  // mannequin's tags predicted facing the camera that no search decoded, the tag's border
  // square is fitted to the image's edges around its predicted corners: along each side's
  // outward normal, within the prediction's reach (the tag centre's predicted image motion
  // since the last measurement plus (1 + frames since) x one frame's, plus
  // roi_min_margin_px), the side's offset where the border's edge (its known polarity) is
  // strongest over the whole side, then each sample's edge at the middle of its blurred
  // ramp (the centroid of the gradient's lobe), a line per side and the corners where the
  // lines meet. Accepted only when (a) no other tag's predicted square (any body) and no
  // decoded tag lies within the reach, (b) each side's line fits within edge_fit_max_rms_px
  // and the square's shape (less its shift) within edge_fit_max_shape_px of the predicted
  // one, the shift within the reach, (c) the frame has at least one decoded tag of the
  // mannequin and the pose fitted to them and the fitted squares puts each fitted square
  // within edge_fit_max_reproj_px RMS (and not out by the outlier test). Fitted squares
  // join the tags (DetectedTag::edge_fit). Not off the path (discovery).
  bool edge_fit = false;
  double edge_fit_min_side_px = 12.0;    // predicted side below this: not tried
  double edge_fit_max_reach_sides = 1.0;  // reach above this x the side: not tried
  double edge_fit_max_reproj_px = 1.0;    // the fitted square under the pose with it (RMS)
  TagEdgeFitOptions edge_fit_border;      // the square's fit (tag_edge_fit.h): edges, rms, shape
  // Issue 28 session 22 (off by default): the cell-pattern fit (tag_pattern_fit.h). For
  // each of the mannequin's tags predicted facing the camera that no search decoded (and,
  // with edge_fit on, that the edge fit did not accept), the tag's known cells are rendered
  // blurred along its predicted motion over the exposure (the filter's pose at capture -
  // exposure/2 and + exposure/2, each corner's image path) and its four corners refined by
  // Gauss-Newton on the photometric error in linear light, brightness and contrast free.
  // Accepted with the edge fit's gates: no other tag's predicted square (any body) or
  // decoded tag overlapping the fitted area (cells plus the blur; the reach is not part of
  // it: the known code tells tags apart, see the cell check), the fit's correlation and cell
  // check (tag_pattern_fit.h), shift within the reach, shape within the options' bound, then
  // pattern_fit_max_reproj_px under the pose with the frame's decoded tags (at least one).
  bool pattern_fit = false;
  // The exposure time the blur is predicted over (s); 0 = half the frame interval.
  double pattern_fit_exposure_s = 0.0;
  // The pattern-fitted square under the pose with it (RMS px), gate (d) above. 0.5 since
  // session 23: on `hard` seeds 5, 11-13 no accepted square over 1 px off (largest 0.87 px;
  // 1.0 px accepted 2.05, 1.53, 1.37, 1.06 px ones), p95 per seed not worse.
  double pattern_fit_max_reproj_px = 0.5;
  TagPatternFitOptions pattern_fit_cells;  // the fit's own options (tag_pattern_fit.h)
  // Measurements whose reprojection RMS exceeds this are rejected (px).
  double max_rms_px = 3.0;
  // Measurements whose position uncertainty (sqrt of the trace of the
  // covariance's translation block, m) exceeds this are rejected: one or two
  // small tags can fit their corners exactly and still be millimetres off in
  // depth (seen on `hard`: 5-9 mm). The covariance is re-scaled to at least
  // sigma_floor_px of corner noise per axis, because an exact fit of 4
  // corners says nothing about the noise (pose_uncertainty.h). 0 = no gate.
  // The floor is the corner noise measured on the generator's footage: with
  // 0.1 px the predicted RMS position error matches the observed one within
  // ~20 % on standard, hard and lowlight (docs/BENCHMARKS.md, issue 16); the
  // mannequin gate, tuned at 1.5 mm with a 0.25 px floor, is 0.6 mm at 0.1.
  // The mirror's gate applies to its centre (85 mm from its tags, what the
  // reflection is drawn from): a reflection less certain than 1 mm is
  // hidden rather than drawn off.
  double mannequin_max_sigma_m = 0.6e-3;
  double mirror_max_sigma_m = 1.0e-3;
  double sigma_floor_px = 0.1;
  // Gate on each tag's own corner noise (BodyTrack::sigma_per_tag_m) instead
  // of one noise shared by all corners.
  bool sigma_per_tag = false;
  // The mirror's (and pen's) corner noise is pooled with the mannequin's of
  // the same frame (pose_uncertainty.h, pooled_noise_px2): same camera and
  // detector, 40-90 residual dof instead of 10. Measured on footage: the
  // mirror centre's sigma against its error 1.15-1.3x without, within 20 %
  // with it (docs/BENCHMARKS.md, issue 16). The mannequin keeps its own.
  bool pool_noise = true;
  // ... and only with the mannequin tags seen no more obliquely than the
  // body's own most oblique tag (pooled_noise_px2, comparable_only). With
  // the 20-tag head (MannequinLayout::kWrap20) pooling all its tags
  // over-stated the mirror centre's sigma 1.26x on `mirror`; comparable
  // tags: 0.89-1.03 at 640x480, but at 1280x720 on `standard` the gated
  // reflections' sigma under-stated their error (0.69x; docs/BENCHMARKS.md,
  // issue 16 head layout). Off: the default 12-tag station was measured with
  // the plain pool.
  bool pool_comparable_tags = false;
  PoseFilterOptions filter;
  bool filter_enabled = true;
  double stale_limit_s = 0.2;  // predicted -> lost after this long without a measurement
  // Also predicted -> lost once the prediction may have drifted this far (m):
  // the body's filtered speed (|v| + |w| x 0.1 m of body extent) times the
  // time since its last measurement. A fast head turn makes a 200 ms-old
  // prediction centimetres wrong (`hard`: 10 mm per frame); better no
  // overlay than a misplaced one. 0 = off (only stale_limit_s).
  double max_prediction_drift_m = 3e-3;
  // A hand-held body (mirror, pen) is predicted between measurements only
  // once its track has this many measurements: the filter's velocity comes
  // from the second, and from one the drift bound above reads 0 while the
  // hand moves it (`fast`: predicted reflections 2.4 mm off after a new
  // one-measurement track). The mannequin's motion is the camera's, checked
  // by the image motion below. 1 = predict from the first.
  int hand_held_measurements_to_predict = 2;
  // The same for the mannequin (issue 16, measured 2026-11-27): 2 = not
  // drawn predicted until its track has two measurements (`hard` 720p: a
  // one-measurement track was predicted 4.7 mm off; p95 0.664 -> 0.550 mm,
  // the same frames drawn); 1 = predicted from its first measurement (the
  // image-motion check below is then its only guard).
  int mannequin_measurements_to_predict = 2;
  // Also predicted -> lost when the whole image moved since the body's last
  // measurement by more than the prediction explains, as an angle of camera
  // rotation (shift px / fx, rad; image_motion.h), or when the frames no
  // longer correlate (phase-correlation peak < min_motion_response). The
  // filter cannot see a head turn that blurred the tags away; the image can
  // (`fast` preset: 79 mm p95 drawn without it). 0 = off.
  double max_prediction_turn_rad = 0.012;  // 0.7 deg: ~4 mm at 35 cm
  double min_motion_response = 0.03;
  // Also track the pen (station.pen, body frame `ptag`) that stands in for
  // the haptic stylus (`dentar live --stylus pen`). Its regions join the fast
  // path like the mirror's; a lost pen is found by the full-frame searches.
  bool track_pen = false;
  double pen_max_sigma_m = 0.0;  // as mirror_max_sigma_m (0 = no gate)
  // Refine each mirror measurement from the disc's rim ellipse in the image
  // (mirror_rim.h): the tag fit as a prior plus the rim's edges, its
  // covariance (and so the gate) from the joint fit; the tag pose when too
  // few rim edges are found. Measured in docs/BENCHMARKS.md (issue 16, the
  // mirror's rim ellipse).
  bool mirror_rim_refine = false;
  MirrorRimOptions mirror_rim;
  // StereoTracker only (issue 28, the mirror through both eyes): refine the
  // mirror's joint fit from its rim ellipse in each eye in turn (the left
  // eye's rim on the joint fit as the prior, then the right eye's on that),
  // each with mirror_rim's options. The stereo fit fixes the depth the rim
  // cannot; the rim fixes the tilt that two 12 mm tags 85 mm from the disc
  // leave. Measured in docs/BENCHMARKS.md (issue 28 session 16).
  bool stereo_mirror_rim = true;
  // With stereo_mirror_rim: hold the disc centre's distance along each eye's
  // line of sight at the prior's (mirror_rim.keep_depth, which one camera
  // needs). false: each eye's rim moves the centre across its own line of
  // sight and the two eyes' rims together fix it in depth too (the rim's
  // image size stays free, mirror_rim.free_scale, so the depth comes from
  // the two views, not from the ellipse's size). A fit whose tags come from
  // one eye only keeps the depth regardless.
  bool stereo_mirror_rim_keep_depth = false;
  // With stereo_mirror_rim: each eye's rim counts as at most this many
  // independent edge points (MirrorRimOptions::rim_effective_points, which
  // the mono rim keeps at 12). The two rims are one disc's outline and share
  // its edge-selection error (issue 16: the edge picked is often a
  // neighbouring step, coherent along the rim), so together they count as
  // mono's one rim. Development seeds 1-4 (issue 28 session 17): 6 / 12 / 24
  // per eye gave `standard` mirror p95 mean 0.431 / 0.460 / 0.688 mm.
  double stereo_mirror_rim_effective_points = 6;
  // With stereo_mirror_rim: the rim is used only when at least this many
  // distinct mirror tags entered the joint fit. One 12 mm tag leaves the
  // disc's tilt nearly free (its planar ambiguity), and the rim's ellipse has
  // a two-fold tilt of its own: on the development clips (seeds 1-2) the
  // one-tag frames refined with the rim were the whole tail (up to 2.4 mm,
  // 4 deg off, stating 0.3 mm), the two- and three-tag frames <= 0.64 mm.
  int stereo_mirror_rim_min_tags = 2;
  // With stereo_mirror_rim (issue 28 session 23, off by default): stereo_mirror_rim_min_tags
  // counts tag sightings (a tag seen by both eyes counts twice), so one tag seen by both eyes
  // gets the rim: its two views fix its position and depth, the rim the tilt that one small tag
  // leaves free (the one-tag frames without a rim were half of `standard` seed 5's tail, p95
  // 0.61 mm, stating 0.8-1.0 mm). One tag in one eye still gets no rim. Not the default: on
  // the development clip `mirror` seed 1 the rim's wrong tilt branch put one-tag frames 1.2-2.2
  // mm off stating 0.43-0.49 mm (without stereo_mirror_rim_one_tag_chi2, below). false =
  // distinct tags (session 17). Measured in docs/BENCHMARKS.md, "Issue 28 session 23 —
  // tracking accuracy".
  bool stereo_mirror_rim_count_sightings = false;
  // With stereo_mirror_rim_count_sightings and one distinct mirror tag: the rim-refined centre is kept only
  // when its shift from the tags-only fit is within this squared Mahalanobis distance of the
  // tags-only fit's centre covariance (chi-square, 3 dof: 11.34 = 99 %); otherwise the tags-only
  // fit stands. The rim's ellipse has a two-fold tilt (`mirror` seed 1: the wrong branch put
  // the centre 1.2-2.2 mm off while stating 0.43-0.49 mm). 0 = no check.
  double stereo_mirror_rim_one_tag_chi2 = 11.34;
  // StereoTracker only: a mirror fit whose tags one eye alone saw states
  // (and is gated on) the depth error that a common outline offset of each
  // tag observation makes, of this many times the corner noise
  // (BundlePoseOptions::tag_outline_sigma; the pose itself is unchanged).
  // One eye reads the depth of the mirror's few small tags from their size,
  // which such an offset moves; two eyes read it from their disparity, and
  // their fits are left as they are. Measured on development seeds 1-4
  // (`standard`): outline offset RMS 0.57x the rest of the corner error, so
  // 0.6 is the measured value. Held out (seeds 5-7): it removes `offframe`
  // 6's one-eye tail (mirror p95 2.087 -> 0.427 mm) and changes no other
  // clip: on by default since session 18 (docs/BENCHMARKS.md, issue 28
  // session 18); 0 turns it off.
  double stereo_mirror_outline_sigma = 0.6;
  // StereoTracker only: a mirror drawn from the filter's prediction states
  // an error that grows with the prediction's age,
  //   sigma(age) = sqrt(sigma_last^2 + (q * age)^2),
  // q the RMS speed (m/s) at the mirror's centre of the motion the filter
  // did not predict over its recent measurements (innovation / frame gap,
  // floored at mirror_min_unexplained_speed_m_s), and is lost once sigma(age)
  // exceeds mirror_max_sigma_m, as a measurement would be. false = the
  // shared drift bound alone (max_prediction_drift_m).
  bool mirror_prediction_sigma = true;
  double mirror_min_unexplained_speed_m_s = 0.005;
  // Where the full-frame search runs (see the top of this file).
  DiscoveryMode discovery = DiscoveryMode::kInline;
  // kAsync: called once on the worker thread before its first search (CPU
  // affinity, scheduling class); may be empty.
  std::function<void()> discovery_thread_init;

  std::string validate() const;  // empty when valid, else names the field
};

struct BodyTrack {
  std::string name;  // "mannequin" or "mirror"
  TrackState state = TrackState::kLost;
  // Filtered and predicted to the display time (the measurement itself when
  // the filter is off); meaningless when lost.
  Eigen::Isometry3d T_cam_body = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cam_body_measured = Eigen::Isometry3d::Identity();  // this frame's PnP
  bool measured = false;  // a pose was measured in this frame
  double rms_px = 0;      // reprojection RMS of the measurement (undistorted px)
  int tags_used = 0;
  std::vector<int> tag_ids;  // ids used, ascending
  int rejected_id = -1;      // a tag the bundle's outlier test left out (BundlePoseOptions::outlier_px), -1 none
  // Covariance of the measurement (bundle_pose.h: (w rad, v m) in `cam`):
  // BundlePose::covariance_per_px2 times the corner noise (the fit's own
  // residual estimate; for the mirror and pen pooled with the mannequin's
  // when TrackerOptions::pool_noise), not floored.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  // Position sigma (m) of the body's gate point (the mannequin's origin, the
  // mirror's centre) from the covariance with one corner noise for all
  // corners (pooled as `covariance`), floored at sigma_floor_px
  // (pose_uncertainty.h); what the gate
  // uses unless TrackerOptions::sigma_per_tag; 0 when not measured.
  double sigma_m = 0;
  // The same point's sigma from the per-tag noise covariance
  // (BundlePose::covariance_per_tag), floored like sigma_m; what the gate
  // uses when TrackerOptions::sigma_per_tag.
  double sigma_per_tag_m = 0;
  double since_measurement_s = 0;  // capture time - last measured capture time
  // TrackerOptions::mirror_rim_refine: rim edges used (0 = the tag pose,
  // not refined, or the option off).
  int rim_points = 0;
};

struct TrackTimings {
  double detect_ms = 0, pose_ms = 0, filter_ms = 0, total_ms = 0;
};

struct TrackFrame {
  std::int64_t index = 0;  // the frame_id given to track(), else its count since create()/reset()
  double capture_time_s = 0, display_time_s = 0;
  bool full_frame = true;  // false: the predicted-region path ran
  int regions = 0;         // crops searched (0 on a full frame)
  double searched_fraction = 1;  // searched pixels / image pixels
  // Pixels converted to grey this frame / image pixels (0 for a grey frame; 1 when a
  // full-frame search or the mirror rim needed the whole frame): frame_gray.h.
  double gray_fraction = 0;
  int tags_detected = 0;
  // Searches repeated in linear light this frame (TrackerOptions::linear_second_look):
  // regions plus the whole frame, 0 when every expected tag was found.
  int second_looks = 0;
  // TrackerOptions::edge_fit: the mannequin's undecoded tags tried, accepted, and refused by
  // reason: [0] ambiguous (another square within reach), [1] no edges (a side without enough
  // edge points or over edge_fit_max_rms_px), [2] off the prediction (shift or shape),
  // [3] inconsistent with the pose fit.
  int edge_fit_tried = 0, edge_fit_accepted = 0;
  std::array<int, 4> edge_fit_refused{};
  // TrackerOptions::pattern_fit: tried, accepted, refused by reason: [0] overlapping another
  // square, [1] no fit (too few pixels, no contrast, diverged), [2] the cell check or the
  // correlation, [3] off the prediction (shift or shape), [4] inconsistent with the pose fit.
  int pattern_fit_tried = 0, pattern_fit_accepted = 0;
  std::array<int, 5> pattern_fit_refused{};
  double pattern_fit_ms = 0;  // thread CPU time in the pattern fit this frame (ms)
  std::vector<DetectedTag> tags;  // all detections, full-image OpenCV pixels
  BodyTrack mannequin, mirror;
  BodyTrack pen;  // lost unless options.track_pen
  TrackTimings timing;
  // Discovery off the frame path (not kInline): this frame's image was handed
  // to a full-frame search; the search started on frame `discovery_merged`
  // (-1: none) was merged before this frame's own search, with
  // `discovery_tags` tags found in `discovery_ms` (its own time, ms).
  bool discovery_started = false;
  std::int64_t discovery_merged = -1;
  int discovery_tags = 0;
  double discovery_ms = 0;
};

class Tracker {
 public:
  // Uses station.calibration.camera (its size must be the images'); the
  // bodies come from mannequin_bundle()/mirror_bundle(). Errors name the
  // option or the station field.
  static Result<Tracker> create(const StationScene& station, const TrackerOptions& options = {});
  Tracker(Tracker&&) noexcept;
  Tracker& operator=(Tracker&&) noexcept;
  ~Tracker();

  // One frame (BGR CV_8UC3, YUYV CV_8UC2 or gray CV_8UC1, the calibration's size;
  // grey levels are made only where they are searched: frame_gray.h),
  // captured at capture_time_s (monotonic, s); poses are predicted to
  // display_time_s (>= capture time; equal = no prediction). Errors: empty or
  // wrong-size/type image (message says which), detector failure, a cue
  // outside kScheduled or one that merges a search never started.
  // frame_id names the frame in TrackFrame::index, discovery_merged and the
  // cues (-1: the tracker's own count of track() calls since create/reset);
  // ids must increase.
  Result<TrackFrame> track(const cv::Mat& image, double capture_time_s, double display_time_s,
                           const DiscoveryCue* cue = nullptr, std::int64_t frame_id = -1);
  // Forgets all bodies (next frame is a full-frame search); waits for and
  // drops a running discovery.
  void reset();
  // The options in use: detector.response resolved (never kAuto).
  const TrackerOptions& options() const;
  // The one-line note when detector.response was auto and the station's
  // response is unknown (resolve_camera_response); else empty.
  const std::string& response_note() const;
  const calibration::CameraIntrinsics& camera() const;

  struct Impl;

 private:
  Tracker() = default;
  std::unique_ptr<Impl> impl_;
};

// ---- Camera model / image size ----

// Intrinsics for another image size: fx, cx scaled by width ratio, fy, cy by
// the height ratio (pixel centres at integers: c' = (c + 0.5) s - 0.5);
// distortion unchanged (it acts on normalised coordinates). Error when the
// aspect ratios differ by more than 0.5 % (a crop, not a scale) or a size is
// not positive.
Result<calibration::CameraIntrinsics> scale_intrinsics(const calibration::CameraIntrinsics& k,
                                                       int width, int height);
// The calibration to use for images of width x height: the calibration
// itself when the sizes match; scaled when `allow_scale`; else an error that
// names both sizes and suggests --scale-calib. `source` names the file.
Result<calibration::CameraIntrinsics> camera_for_image(const calibration::CameraIntrinsics& k,
                                                       int width, int height, bool allow_scale,
                                                       const std::string& source);
// Reads a camera calibration: a station JSON (station_scene.h, its
// calibration.camera) or an OpenCV FileStorage / ROS camera_info YAML
// (calibration/camera_file.h). Errors name the file and field.
Result<calibration::CameraIntrinsics> read_camera_calibration(const std::string& path);

// ---- Per-tag poses (`dentar track --tags`) ----

struct TagPose {
  TagFamilyId family = TagFamilyId::kStandard41h12;
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners_px;  // detected (distorted) OpenCV px
  // Tag frame per libapriltag (station_scene.h): the better of the two
  // IPPE_SQUARE solutions (lower reprojection RMS on the undistorted corners).
  Eigen::Isometry3d T_cam_tag = Eigen::Isometry3d::Identity();
  double rms_px = 0;
  Eigen::Isometry3d T_cam_tag_alt = Eigen::Isometry3d::Identity();  // the other solution
  double alt_rms_px = 0;  // its RMS (a ratio alt/best near 1 = ambiguous)
  bool ok = false;
};
// Every detection's own pose for a square tag of side tag_size_m (m).
std::vector<TagPose> estimate_tag_poses(const std::vector<DetectedTag>& tags,
                                        const calibration::CameraIntrinsics& camera,
                                        double tag_size_m);

}  // namespace dentar::ar
