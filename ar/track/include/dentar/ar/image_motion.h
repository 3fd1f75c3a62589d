// Global image motion between a body's last measured frame and now, from
// the phase correlation of small thumbnails: the check that keeps the
// tracker from coasting on a prediction while the head turns (issue 16).
//
// When a body's tags are not found, the tracker draws the filter's
// prediction for up to 200 ms. The filter only knows the motion it measured
// before the dropout; a head turn at 200-300 deg/s that blurs the tags away
// is invisible to it and the stale pose is drawn centimetres off. The
// camera's own rotation moves the whole image, which this measures: a shift
// that the prediction does not explain (or content that no longer
// correlates) ends the prediction.
//
// Cost: one area resize to 160 px width and one 160x(120|90) DFT pair per
// call, ~0.2 ms. Not thread-safe (scratch buffers); one per tracker.
#pragma once

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace dentar::ar {

class ImageMotion {
 public:
  static constexpr int kThumbWidth = 160;

  // Makes `gray` (CV_8UC1, full frame) the thumbnail of the current frame.
  // px_per_gray_px: full-image pixels per pixel of `gray` (> 1 when `gray` is a
  // decimated copy of the frame).
  void set_frame(const cv::Mat& gray, double px_per_gray_px = 1.0);
  // The same from the frame as delivered (BGR, YUYV or grey; see frame_gray.h),
  // read at every k-th pixel of every k-th row, k = max(1, floor(width / 640)):
  // the thumbnail's input is at most ~640 px wide, so its cost stays that of a
  // 640x480 frame at any resolution (issue 28). At 640 px wide and below it is
  // exactly set_frame of the whole grey frame. Above, the 4x area filter down to
  // the thumbnail follows a point sampling; measured shifts agree with the whole
  // frame's within 0.5 px of the full image at 1920x1080 (tested).
  void set_frame_from_image(const cv::Mat& image);
  static int decimation_for_width(int width) { return width >= 1280 ? width / 640 : 1; }
  // Copies the current frame's thumbnail into `ref` (a body's reference,
  // taken when it is measured); reuses ref's buffer.
  void keep(cv::Mat& ref) const;
  struct Shift {
    Eigen::Vector2d px = Eigen::Vector2d::Zero();  // image content moved by this (full-image px)
    double response = 0;  // phase-correlation peak, 0..1 (low: the content changed)
    bool valid = false;   // false when ref is empty or of another size
  };
  // The shift of the current frame against `ref`.
  Shift shift_since(const cv::Mat& ref) const;

 private:
  cv::Mat thumb_, window_, small_;
  double scale_ = 1;  // full-image px per thumbnail px
};

}  // namespace dentar::ar
