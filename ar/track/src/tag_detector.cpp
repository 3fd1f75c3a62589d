#include "dentar/ar/tag_detector.h"

#include <apriltag/apriltag.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <string>
#include <utility>

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

}  // namespace

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
      detector_(std::move(o.detector_)) {}

TagDetector& TagDetector::operator=(TagDetector&& o) noexcept {
  if (this != &o) {
    reset();
    options_ = std::move(o.options_);
    families_ = std::move(o.families_);
    detector_ = std::move(o.detector_);
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
  image_u8_t im{gray.cols, gray.rows, static_cast<int32_t>(gray.step[0]), gray.data};
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
