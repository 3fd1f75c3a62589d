#include "dentar/ar/tag_detector.h"

#include <apriltag/apriltag.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
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

// srgb_decode of 8-bit codes to 8-bit linear light.
const cv::Mat& srgb_to_linear_lut() {
  static const cv::Mat lut = [] {
    cv::Mat t(1, 256, CV_8U);
    for (int i = 0; i < 256; ++i)
      t.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(std::lround(255.0 * srgb_decode(i / 255.0)));
    return t;
  }();
  return lut;
}

// Bilinear sample of an 8-bit image at OpenCV coordinates; NaN outside.
double sample_px(const cv::Mat& im, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= im.cols || y0 + 1 >= im.rows) return NAN;
  const double a = x - x0, b = y - y0;
  const std::uint8_t* r0 = im.ptr<std::uint8_t>(y0);
  const std::uint8_t* r1 = im.ptr<std::uint8_t>(y0 + 1);
  return (1 - b) * ((1 - a) * r0[x0] + a * r0[x0 + 1]) + b * ((1 - a) * r1[x0] + a * r1[x0 + 1]);
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
bool refit_edges_linear(const cv::Mat& im, int width_at_border, std::array<Eigen::Vector2d, 4>& c) {
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
      const double vi = sample_px(im, pi.x(), pi.y()), vo = sample_px(im, po.x(), po.y());
      if (std::isnan(vi) || std::isnan(vo)) return false;
      lin.push_back(vi);
      lout.push_back(vo);
    }
    std::nth_element(lin.begin(), lin.begin() + samples / 2, lin.end());
    std::nth_element(lout.begin(), lout.begin() + samples / 2, lout.end());
    const double vin = lin[samples / 2], vout = lout[samples / 2];
    if (std::abs(vin - vout) < 8.0) return false;
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    std::vector<Eigen::Vector2d> pts;
    for (int s = 0; s < samples; ++s) {
      const Eigen::Vector2d p = a + (0.15 + 0.7 * (s + 0.5) / samples) * (b - a);
      double e = 0;
      bool ok = true;
      for (int it = 0; it < 2 && ok; ++it) {
        double sum = 0;
        for (double x = -w + step / 2; x < w; x += step) {
          const Eigen::Vector2d q = p + n * (e + x);
          const double v = sample_px(im, q.x(), q.y());
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
      m += pts.back();
    }
    if (pts.size() < 4) return false;
    m /= static_cast<double>(pts.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& q : pts) cov += (q - m) * (q - m).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
    const Eigen::Vector2d normal = es.eigenvectors().col(0);  // smallest spread
    lines[k] = Eigen::Vector3d(normal.x(), normal.y(), -normal.dot(m));
  }
  std::array<Eigen::Vector2d, 4> out;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k-1 (corner k-1 -> k) and edge k.
    const Eigen::Vector3d x = lines[(k + 3) % 4].cross(lines[k]);
    if (std::abs(x.z()) < 1e-9) return false;
    out[k] = x.head<2>() / x.z();
    if ((out[k] - c[k]).norm() > 1.0) return false;
  }
  c = out;
  return true;
}

}  // namespace

const char* camera_response_name(CameraResponse r) {
  return r == CameraResponse::kSrgb ? "srgb" : "linear";
}

Result<CameraResponse> parse_camera_response(const std::string& name) {
  if (name == "srgb") return CameraResponse::kSrgb;
  if (name == "linear") return CameraResponse::kLinear;
  return Error{"camera response \"" + name + "\" is not one of: srgb, linear"};
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
  if (response != CameraResponse::kLinear && response != CameraResponse::kSrgb)
    return "response = " + std::to_string(static_cast<int>(response)) + " is not linear or srgb";
  if (max_bits_corrected < 0 || max_bits_corrected > 3)
    return "max_bits_corrected = " + std::to_string(max_bits_corrected) + " must be in 0..3";
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
  return t;
}

TagDetector::TagDetector(TagDetector&& o) noexcept
    : options_(std::move(o.options_)),
      families_(std::move(o.families_)),
      detector_(std::move(o.detector_)),
      linear_(std::move(o.linear_)) {}

TagDetector& TagDetector::operator=(TagDetector&& o) noexcept {
  if (this != &o) {
    reset();
    options_ = std::move(o.options_);
    families_ = std::move(o.families_);
    detector_ = std::move(o.detector_);
    linear_ = std::move(o.linear_);
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
  // libapriltag reads rows through `stride`; a ROI view of a larger Mat works
  // as is, only a non-uniform layout would need a copy (never for 2-D Mats).
  const cv::Mat* src = &gray;
  if (options_.response == CameraResponse::kSrgb) {
    cv::LUT(gray, srgb_to_linear_lut(), linear_);  // reuses the buffer at the same size
    src = &linear_;
  }
  image_u8_t im{src->cols, src->rows, static_cast<int32_t>(src->step[0]), src->data};
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
    if (options_.refit_edges_linear) {
      for (const TagFamily& f : families_)
        if (f.raw() == d->family) refit_edges_linear(*src, f.width_at_border(), t.corners_px);
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
