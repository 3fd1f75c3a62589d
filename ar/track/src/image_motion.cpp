#include "dentar/ar/image_motion.h"

#include "dentar/ar/frame_gray.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dentar::ar {

void ImageMotion::set_frame(const cv::Mat& gray, double px_per_gray_px) {
  const double s = double(gray.cols) / kThumbWidth;  // gray px per thumbnail px
  scale_ = s * px_per_gray_px;
  const int h = std::max(8, static_cast<int>(gray.rows / s + 0.5));
  cv::Mat small;
  cv::resize(gray, small, cv::Size(kThumbWidth, h), 0, 0, cv::INTER_AREA);
  small.convertTo(thumb_, CV_32F);
  if (window_.size() != thumb_.size()) cv::createHanningWindow(window_, thumb_.size(), CV_32F);
}

void ImageMotion::set_frame_from_image(const cv::Mat& image) {
  const int k = decimation_for_width(image.cols);
  decimated_gray(image, k, small_);
  set_frame(small_, k);
}

void ImageMotion::keep(cv::Mat& ref) const { thumb_.copyTo(ref); }

ImageMotion::Shift ImageMotion::shift_since(const cv::Mat& ref) const {
  Shift s;
  if (ref.empty() || thumb_.empty() || ref.size() != thumb_.size()) return s;
  double response = 0;
  // phaseCorrelate(a, b) returns how far b's content is shifted from a's.
  const cv::Point2d d = cv::phaseCorrelate(ref, thumb_, window_, &response);
  s.px = Eigen::Vector2d(d.x, d.y) * scale_;
  s.response = response;
  s.valid = std::isfinite(d.x) && std::isfinite(d.y);
  return s;
}

}  // namespace dentar::ar
