#include "dentar/ar/tag_detector.h"

#include <apriltag/apriltag.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/srgb.h"

namespace dentar::ar {

namespace {

std::string check_decimation(double d) {
  if (!std::isfinite(d) || d < 1.0 || d > 16.0)
    return "decimation = " + std::to_string(d) + " must be in [1, 16]";
  return {};
}

std::string check_threads(int n) {
  if (n < 1 || n > 64) return "threads = " + std::to_string(n) + " must be in 1..64";
  return {};
}

// An 8-bit image read through a response table: grey code -> linear light
// scaled to 0..255 (not rounded to integers: sRGB spreads the dark codes over
// few linear levels; held as double so that a read converts nothing).
// Bilinear in linear light.
struct LinearView {
  const cv::Mat& im;
  const std::array<double, 256>& lut;
  // NaN outside the image; OpenCV coordinates.
  double at(double x, double y) const {
    // Inside (NaN is not): from 0 on, truncation is floor (std::floor
    // costs ~15 instructions without SSE4.1).
    if (!(x >= 0 && y >= 0 && x < im.cols - 1 && y < im.rows - 1)) return NAN;
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double a = x - x0, b = y - y0;
    const std::uint8_t* r0 = im.ptr<std::uint8_t>(y0);
    const std::uint8_t* r1 = im.ptr<std::uint8_t>(y0 + 1);
    return (1 - b) * ((1 - a) * lut[r0[x0]] + a * lut[r0[x0 + 1]]) +
           b * ((1 - a) * lut[r1[x0]] + a * lut[r1[x0 + 1]]);
  }
  // at(start + i * step) for i = 0 .. count - 1 into out[0 .. count - 1];
  // false when any is outside the image. The points lie on a segment: when
  // both ends are inside, all are, and the per-point checks are skipped
  // (the margin covers the rounding of the position stepped by additions).
  bool along(const Eigen::Vector2d& start, const Eigen::Vector2d& step, int count, double* out) const {
    const Eigen::Vector2d end = start + step * (count - 1);
    auto inside = [&](const Eigen::Vector2d& q) {
      return q.x() >= 1e-6 && q.y() >= 1e-6 && q.x() < im.cols - 1.000001 && q.y() < im.rows - 1.000001;
    };
    if (!inside(start) || !inside(end)) {
      for (int i = 0; i < count; ++i) {
        const Eigen::Vector2d q = start + step * i;
        const double v = at(q.x(), q.y());
        if (std::isnan(v)) return false;
        out[i] = v;
      }
      return true;
    }
    const std::size_t stride = im.step[0];
    const std::uint8_t* base = im.ptr<std::uint8_t>(0);
    const double* l = lut.data();
    double x = start.x(), y = start.y();
    const double dx = step.x(), dy = step.y();
    for (int i = 0; i < count; ++i, x += dx, y += dy) {
      const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);  // >= 0: floor
      const double a = x - x0, b = y - y0;
      const std::uint8_t* r0 = base + static_cast<std::size_t>(y0) * stride + x0;
      const std::uint8_t* r1 = r0 + stride;
      const double top = l[r0[0]] + a * (l[r0[1]] - l[r0[0]]);
      const double bottom = l[r1[0]] + a * (l[r1[1]] - l[r1[0]]);
      out[i] = top + b * (bottom - top);
    }
    return true;
  }
};

// Total least-squares line through points: (n, d) with n.x + d = 0.
Eigen::Vector3d fit_line(const std::vector<Eigen::Vector2d>& pts) {
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (const auto& q : pts) m += q;
  m /= static_cast<double>(pts.size());
  double sxx = 0, sxy = 0, syy = 0;  // scatter matrix [sxx sxy; sxy syy]
  for (const auto& q : pts) {
    const Eigen::Vector2d d = q - m;
    sxx += d.x() * d.x();
    sxy += d.x() * d.y();
    syy += d.y() * d.y();
  }
  // The normal is the eigenvector of the smaller eigenvalue, in closed form
  // (a tenth of Eigen's iterative 2x2 solver's work): of the two rows of
  // (S - lambda I), both orthogonal to it, the longer one gives it stably.
  const double half = 0.5 * (sxx - syy);
  const double lambda = 0.5 * (sxx + syy) - std::sqrt(half * half + sxy * sxy);
  const Eigen::Vector2d r0(sxx - lambda, sxy), r1(sxy, syy - lambda);
  const Eigen::Vector2d r = r0.squaredNorm() >= r1.squaredNorm() ? r0 : r1;
  const double len = r.norm();
  // Points all at one place: no direction (any normal; the caller's corner
  // checks reject what follows).
  const Eigen::Vector2d normal = len > 0 ? Eigen::Vector2d(-r.y() / len, r.x() / len) : Eigen::Vector2d(1, 0);
  return {normal.x(), normal.y(), -normal.dot(m)};
}

// Corners where consecutive lines meet; false when two are parallel or a
// corner moves more than max_move_px from `c`.
bool intersect_lines(const std::array<Eigen::Vector3d, 4>& lines, double max_move_px,
                     std::array<Eigen::Vector2d, 4>& c) {
  std::array<Eigen::Vector2d, 4> out;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k-1 (corner k-1 -> k) and edge k.
    const Eigen::Vector3d x = lines[(k + 3) % 4].cross(lines[k]);
    if (std::abs(x.z()) < 1e-9) return false;
    out[k] = x.head<2>() / x.z();
    if (!out[k].allFinite() || (out[k] - c[k]).norm() > max_move_px) return false;
  }
  c = out;
  return true;
}

// The centroid (px along the normal) of the squared gradient of the edge's
// sign over the window of `steps` 0.25 px samples starting at level index
// `first` of lv (lv[j] at -range - 1 + j / 4; the gradient at sample j is
// lv[j + 8] - lv[j], at -range + j / 4). False when no gradient has the
// edge's sign or the centroid lies beyond +-range.
bool window_centroid(const double* lv, int first, int steps, double range, double polarity, double& off) {
  double mj = 0, mw = 0, jd = first;  // moment in level indices, weight
  for (int j = first; j < first + steps; ++j, jd += 1) {
    const double g = polarity * (lv[j + 8] - lv[j]);
    if (g <= 0) continue;  // a gradient the wrong way: another edge
    mj += g * g * jd;
    mw += g * g;
  }
  if (mw <= 0) return false;
  off = -range + 0.25 * (mj / mw);
  return std::abs(off) <= range;
}

// Edges this long (px) and longer centre the refit's second window to
// 0.25 px (below: refit_edges_gradient).
constexpr double kSnapFromPx = 32.0;

// The gradient-peak edge refit libapriltag does (refine_edges), but on the
// linear light `im`: for points along each edge, the centroid of the
// squared gradient across it (central difference over +-1 px) within
// +-range px, counting only gradients of the edge's own sign (read from
// the levels a cell inside and a cell outside); a line through the points,
// corners where the lines meet. In linear light a blurred edge's gradient
// peaks where the edge is; on sRGB-encoded grey levels it moves toward the
// bright side. False (corners unchanged) when an edge gives too few points
// or a corner would move more than 1.5 px.
bool refit_edges_gradient(const LinearView& im, int width_at_border, double range,
                          std::array<Eigen::Vector2d, 4>& c) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : c) centre += p / 4;
  std::array<Eigen::Vector3d, 4> lines;
  std::vector<Eigen::Vector2d> pts;
  // Gradient samples per window (0.25 px over +-range), levels they read,
  // and room on either side for the second window's shift (< steps).
  const int steps = static_cast<int>(std::floor(8 * range + 4e-8)) + 1;
  const int levels = steps + 8, head = steps;
  std::vector<double> buf(static_cast<std::size_t>(levels + 2 * head));
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = c[k], b = c[(k + 1) % 4];
    const double len = (b - a).norm();
    if (len < 4.0) return false;
    const double cell = len / width_at_border;
    Eigen::Vector2d n((a - b).y(), (b - a).x());
    n /= len;
    if (n.dot((a + b) / 2 - centre) < 0) n = -n;  // outward
    // Polarity: the mean level half a cell outside minus half a cell inside.
    const double probe = std::clamp(0.5 * cell, 1.0, 4.0);
    double sign_sum = 0;
    const int samples = std::max(8, static_cast<int>(len / 4));
    // A sign: 8 probes along the edge are plenty (issue 24 session 14; they
    // were one per point, up to 25 on a 100 px edge).
    constexpr int probes = 8;
    for (int s = 0; s < probes; ++s) {
      const Eigen::Vector2d p = a + ((s + 0.5) / probes) * (b - a);
      const Eigen::Vector2d po = p + n * probe, pi = p - n * probe;
      const double vo = im.at(po.x(), po.y()), vi = im.at(pi.x(), pi.y());
      if (!std::isnan(vo) && !std::isnan(vi)) sign_sum += vo - vi;
    }
    const double polarity = sign_sum >= 0 ? 1.0 : -1.0;
    pts.clear();
    for (int s = 0; s < samples; ++s) {
      // Stay off the corners' own blur (1 px either end at least).
      const double alpha = (s + 0.5) / samples;
      const Eigen::Vector2d p = a + alpha * (b - a);
      if (alpha * len < 1.0 || (1 - alpha) * len < 1.0) continue;
      // Twice: the second window centred on the first estimate (the start,
      // libapriltag's edge on the encoded image, can be 0.3-0.6 px off, and a
      // window off-centre pulls the centroid toward its middle). The gradient
      // at x (0.25 px steps) is I(x + 1) - I(x - 1): both lie on one 0.25 px
      // grid, lv[j] = I(p + n (-range - 1 + j / 4)), each level read once
      // (issue 24 session 12). On edges of kSnapFromPx and longer the second
      // window is centred on the first estimate rounded to that grid, so it
      // reuses the first window's levels and reads only the |shift| new ones
      // at one end (issue 24 session 14: the second pass was half the
      // refit's reads; on the real photos most points shift by 0 and read
      // nothing more). Shorter edges (8 points each: every point's error
      // goes into the line) keep the window exactly on the estimate.
      double* lv = buf.data() + head;
      if (!im.along(p + n * (-range - 1), n * 0.25, levels, lv)) continue;
      double off = 0;
      if (!window_centroid(lv, 0, steps, range, polarity, off)) continue;
      const int shift = static_cast<int>(std::lround(4 * off));  // |shift| <= 4 range < head
      if (len < kSnapFromPx) {
        // A small tag: the second window exactly on the first estimate.
        const double first = off;
        if (!im.along(p + n * (first - range - 1), n * 0.25, levels, lv)) continue;
        if (!window_centroid(lv, 0, steps, range, polarity, off)) continue;
        off += first;
        if (std::abs(off) > range) continue;
      } else if (shift != 0) {
        const int first = shift > 0 ? levels : shift;  // the new levels' indices
        if (!im.along(p + n * (-range - 1 + 0.25 * first), n * 0.25, std::abs(shift), lv + first))
          continue;
        if (!window_centroid(lv, shift, steps, range, polarity, off)) continue;
      }
      pts.push_back(p + n * off);
    }
    if (pts.size() < 4) return false;
    lines[k] = fit_line(pts);
  }
  return intersect_lines(lines, 1.5, c);
}

// Re-fits the border square's four edges of one detection in the (linear)
// image `im`: across each edge, over a window of +-w (half a cell: the
// border ring inside and the ring outside are one cell wide and uniform),
// the inside-like fraction (I - out) / (in - out) integrates to w + offset
// for an edge `offset` outward, whatever the blur, as long as the light is
// linear. Points along the middle 70 % of the edge, twice (the second time
// centred on the first estimate), a line through them, corners where the
// lines meet. False (corners unchanged) for small tags, low contrast, or a
// corner moving more than 1 px.
bool refit_edges_linear(const LinearView& im, int width_at_border, std::array<Eigen::Vector2d, 4>& c) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const auto& p : c) centre += p / 4;
  std::array<Eigen::Vector3d, 4> lines;  // (n, -n.p0): n.x + d = 0
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = c[k], b = c[(k + 1) % 4];
    const double len = (b - a).norm();
    const double cell = len / width_at_border;
    if (cell < 3.0) return false;
    Eigen::Vector2d n((a - b).y(), (b - a).x());
    n /= len;
    if (n.dot((a + b) / 2 - centre) < 0) n = -n;
    const double w = std::min(0.5 * cell, 4.0), step = 0.25;
    const int samples = std::clamp(static_cast<int>(len / 1.5), 6, 24);
    // Levels of the two rings, median along the edge (robust to one bad sample).
    std::vector<double> lin, lout;
    for (int s = 0; s < samples; ++s) {
      const Eigen::Vector2d p = a + (0.15 + 0.7 * (s + 0.5) / samples) * (b - a);
      const Eigen::Vector2d pi = p - n * w, po = p + n * w;
      const double vi = im.at(pi.x(), pi.y()), vo = im.at(po.x(), po.y());
      if (std::isnan(vi) || std::isnan(vo)) return false;
      lin.push_back(vi);
      lout.push_back(vo);
    }
    std::nth_element(lin.begin(), lin.begin() + samples / 2, lin.end());
    std::nth_element(lout.begin(), lout.begin() + samples / 2, lout.end());
    const double vin = lin[samples / 2], vout = lout[samples / 2];
    if (std::abs(vin - vout) < 8.0) return false;
    std::vector<Eigen::Vector2d> pts;
    for (int s = 0; s < samples; ++s) {
      const Eigen::Vector2d p = a + (0.15 + 0.7 * (s + 0.5) / samples) * (b - a);
      double e = 0;
      bool ok = true;
      for (int it = 0; it < 2 && ok; ++it) {
        double sum = 0;
        for (double x = -w + step / 2; x < w; x += step) {
          const Eigen::Vector2d q = p + n * (e + x);
          const double v = im.at(q.x(), q.y());
          if (std::isnan(v)) {
            ok = false;
            break;
          }
          sum += std::clamp((v - vout) / (vin - vout), -0.5, 1.5) * step;
        }
        // The window [e - w, e + w] holds (edge - (e - w)) of inside.
        e = e - w + sum;
        if (std::abs(e) > 1.5) ok = false;
      }
      if (!ok) continue;
      pts.push_back(p + n * e);
    }
    if (pts.size() < 4) return false;
    lines[k] = fit_line(pts);
  }
  return intersect_lines(lines, 1.0, c);
}

}  // namespace

const char* camera_response_name(CameraResponse r) {
  switch (r) {
    case CameraResponse::kLinear: return "linear";
    case CameraResponse::kSrgb: return "srgb";
    case CameraResponse::kCurve: return "curve";
    case CameraResponse::kAuto: return "auto";
  }
  return "?";
}

Result<CameraResponse> parse_camera_response(const std::string& name) {
  if (name == "auto") return CameraResponse::kAuto;
  if (name == "srgb") return CameraResponse::kSrgb;
  if (name == "linear") return CameraResponse::kLinear;
  if (name == "curve")
    return Error{"camera response \"curve\": a measured curve comes from the station file "
                 "(camera.response, written by dentar calibrate camera); use auto"};
  return Error{"camera response \"" + name + "\" is not one of: auto, srgb, linear"};
}

std::string TagDetectorOptions::validate() const {
  if (families.empty()) return "families: at least one tag family is needed";
  for (std::size_t i = 0; i < families.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (families[i] == families[j])
        return "families[" + std::to_string(i) + "] = " + tag_family_name(families[i]) +
               " is listed twice";
  if (auto e = check_decimation(decimation); !e.empty()) return e;
  if (auto e = check_threads(threads); !e.empty()) return e;
  if (!std::isfinite(blur_sigma) || blur_sigma < 0 || blur_sigma > 10)
    return "blur_sigma = " + std::to_string(blur_sigma) + " px must be in [0, 10]";
  if (response == CameraResponse::kAuto)
    return "response = auto must be resolved from the station first (resolve_camera_response)";
  if (response != CameraResponse::kLinear && response != CameraResponse::kSrgb &&
      response != CameraResponse::kCurve)
    return "response = " + std::to_string(static_cast<int>(response)) + " is not linear, srgb or curve";
  if (response == CameraResponse::kCurve) {
    if (response_curve.size() != 256)
      return "response_curve has " + std::to_string(response_curve.size()) + " entries, needs 256";
    for (std::size_t i = 0; i < 256; ++i)
      if (!std::isfinite(response_curve[i]) || response_curve[i] < 0 || response_curve[i] > 1 ||
          (i > 0 && response_curve[i] < response_curve[i - 1]))
        return "response_curve[" + std::to_string(i) +
               "] is outside [0, 1] or below the entry before (the curve must not decrease)";
    if (!(response_curve[255] > response_curve[0])) return "response_curve is flat";
  }
  if (max_bits_corrected < 0 || max_bits_corrected > 3)
    return "max_bits_corrected = " + std::to_string(max_bits_corrected) + " must be in 0..3";
  if (corner_candidates < 4 || corner_candidates > 20)
    return "corner_candidates = " + std::to_string(corner_candidates) +
           " must be in 4..20 (a quad needs 4 corners)";
  return {};
}

void TagDetector::DetectorDeleter::operator()(apriltag_detector* d) const noexcept {
  apriltag_detector_destroy(d);
}

Result<TagDetector> TagDetector::create(const TagDetectorOptions& options) {
  if (auto e = options.validate(); !e.empty()) return Error{"TagDetectorOptions: " + e};
  TagDetector t;
  t.options_ = options;
  t.detector_.reset(apriltag_detector_create());
  if (!t.detector_) return Error{"TagDetector: apriltag_detector_create failed (out of memory?)"};
  for (TagFamilyId id : options.families) {
    t.families_.push_back(TagFamily::create(id));
    if (t.families_.back().raw() == nullptr)
      return Error{std::string("TagDetector: cannot create family ") + tag_family_name(id)};
    apriltag_detector_add_family_bits(t.detector_.get(), t.families_.back().raw(),
                                      options.max_bits_corrected);
  }
  // libapriltag silently returns no detections when a family failed to
  // register (e.g. its decode table could not be allocated): check here.
  if (zarray_size(t.detector_->tag_families) != static_cast<int>(options.families.size()))
    return Error{"TagDetector: libapriltag refused a family (decode table for " +
                 std::to_string(options.max_bits_corrected) +
                 " corrected bits too large?); lower max_bits_corrected"};
  t.detector_->quad_decimate = static_cast<float>(options.decimation);
  t.detector_->quad_sigma = static_cast<float>(options.blur_sigma);
  t.detector_->nthreads = options.threads;
  t.detector_->refine_edges = options.refine_edges;
  t.detector_->decode_sharpening = 0.25;  // libapriltag's default, set explicitly
  t.detector_->debug = false;
  t.detector_->qtp.max_nmaxima = options.corner_candidates;
  for (int i = 0; i < 256; ++i)
    t.to_linear_[static_cast<std::size_t>(i)] = static_cast<float>(
        options.response == CameraResponse::kSrgb    ? 255.0 * srgb_decode(i / 255.0)
        : options.response == CameraResponse::kCurve ? 255.0 * options.response_curve[static_cast<std::size_t>(i)]
                                                     : i);
  return t;
}

TagDetector::TagDetector(TagDetector&& o) noexcept
    : options_(std::move(o.options_)),
      families_(std::move(o.families_)),
      detector_(std::move(o.detector_)),
      to_linear_(o.to_linear_) {}

TagDetector& TagDetector::operator=(TagDetector&& o) noexcept {
  if (this != &o) {
    reset();
    options_ = std::move(o.options_);
    families_ = std::move(o.families_);
    detector_ = std::move(o.detector_);
    to_linear_ = o.to_linear_;
  }
  return *this;
}

TagDetector::~TagDetector() { reset(); }

void TagDetector::reset() noexcept {
  // apriltag_detector_destroy frees the decode tables it keeps inside the
  // families, so the families must still exist when it runs.
  detector_.reset();
  families_.clear();
}

Status TagDetector::set_decimation(double decimation) {
  if (auto e = check_decimation(decimation); !e.empty()) return Error{"TagDetector: " + e};
  options_.decimation = decimation;
  if (detector_) detector_->quad_decimate = static_cast<float>(decimation);
  return {};
}

Status TagDetector::set_threads(int threads) {
  if (auto e = check_threads(threads); !e.empty()) return Error{"TagDetector: " + e};
  options_.threads = threads;
  if (detector_) detector_->nthreads = threads;
  return {};
}

void TagDetector::set_refine_edges(bool on) {
  options_.refine_edges = on;
  if (detector_) detector_->refine_edges = on;
}

Result<std::vector<DetectedTag>> TagDetector::detect(const cv::Mat& gray) {
  if (!detector_) return Error{"TagDetector::detect: detector was moved from"};
  if (gray.empty()) return Error{"TagDetector::detect: empty image"};
  if (gray.type() != CV_8UC1)
    return Error{"TagDetector::detect: image type " + cv::typeToString(gray.type()) +
                 " is not CV_8UC1 (8-bit grayscale); convert with cv::cvtColor first"};
  if (gray.dims != 2 || gray.cols < 8 || gray.rows < 8)
    return Error{"TagDetector::detect: image " + std::to_string(gray.cols) + "x" +
                 std::to_string(gray.rows) + " px is smaller than 8x8 px"};
  // libapriltag searches and decodes the image as the camera delivered it
  // (its thresholds and decoding are tuned for that; a linearised copy is
  // darker and lost 36 of 47 tags on real photographs, issue 24). Linear
  // light is used only below, to refit the edges. libapriltag reads rows
  // through `stride`: a ROI view of a larger Mat works as is.
  return run(gray, gray);
}

Result<std::vector<DetectedTag>> TagDetector::detect_in_linear_light(const cv::Mat& gray) {
  if (!detector_) return Error{"TagDetector::detect_in_linear_light: detector was moved from"};
  if (options_.response == CameraResponse::kLinear)
    return Error{"TagDetector::detect_in_linear_light: the response is linear (the image already is)"};
  if (gray.empty() || gray.type() != CV_8UC1 || gray.dims != 2 || gray.cols < 8 || gray.rows < 8)
    return detect(gray);  // the same errors
  if (search_lut_.empty()) {
    search_lut_.create(1, 256, CV_8U);
    for (int i = 0; i < 256; ++i)
      search_lut_.at<std::uint8_t>(i) = static_cast<std::uint8_t>(
          std::lround(std::clamp(to_linear_[static_cast<std::size_t>(i)], 0.0, 255.0)));
  }
  cv::LUT(gray, search_lut_, linear_);  // reuses the buffer at the same size
  return run(gray, linear_);
}

Result<std::vector<DetectedTag>> TagDetector::run(const cv::Mat& gray, const cv::Mat& search) {
  image_u8_t im{search.cols, search.rows, static_cast<int32_t>(search.step[0]), search.data};
  zarray_t* found = apriltag_detector_detect(detector_.get(), &im);
  if (found == nullptr) return Error{"TagDetector::detect: libapriltag failed"};
  std::vector<DetectedTag> out;
  out.reserve(static_cast<std::size_t>(zarray_size(found)));
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(found, i, &d);
    DetectedTag t;
    for (const TagFamily& f : families_)
      if (f.raw() == d->family) t.family = f.id();
    t.id = d->id;
    t.hamming = d->hamming;
    t.decision_margin = d->decision_margin;
    // libapriltag puts pixel centres at (0.5, 0.5), OpenCV at (0, 0).
    for (int k = 0; k < 4; ++k)
      t.corners_px[k] = Eigen::Vector2d(d->p[k][0] - 0.5, d->p[k][1] - 0.5);
    if (options_.response != CameraResponse::kLinear) {
      const LinearView lin{gray, to_linear_};
      for (const TagFamily& f : families_) {
        if (f.raw() != d->family) continue;
        // libapriltag's gradient-peak refit again, now in linear light.
        if (options_.refine_edges)
          refit_edges_gradient(lin, f.width_at_border(), options_.decimation + 1, t.corners_px);
        if (options_.refit_edges_linear) refit_edges_linear(lin, f.width_at_border(), t.corners_px);
      }
    } else if (options_.refit_edges_linear) {
      const LinearView lin{gray, to_linear_};
      for (const TagFamily& f : families_)
        if (f.raw() == d->family) refit_edges_linear(lin, f.width_at_border(), t.corners_px);
    }
    out.push_back(t);
  }
  apriltag_detections_destroy(found);
  // Deterministic order whatever the worker pool did.
  std::sort(out.begin(), out.end(), [](const DetectedTag& a, const DetectedTag& b) {
    return a.family != b.family ? a.family < b.family : a.id < b.id;
  });
  return out;
}

}  // namespace dentar::ar
