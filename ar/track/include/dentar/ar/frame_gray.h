// The tracker's grey image, made only where it is read (issue 28, a frame
// cost that follows the overlay).
//
// A frame arrives as the camera (or the decoder) delivers it:
//   CV_8UC3  BGR (OpenCV's decoders, the generator, recorded footage)
//   CV_8UC2  YUYV 4:2:2 (Y0 U Y1 V: a UVC camera's own format), ITU-R BT.601
//            with luma in 16..235 (what OpenCV's COLOR_YUV2BGR_YUYV assumes)
//   CV_8UC1  grey already
// The tag search reads the grey image in the predicted regions only; the whole
// frame is needed only for a full-frame search. FrameGray converts a rectangle
// when it is first asked for and remembers what it converted this frame, so a
// frame tracked in its regions converts only those.
//
// Grey levels: BGR gives OpenCV's COLOR_BGR2GRAY exactly (on the rectangle, the
// same values as the whole frame converted). YUYV gives the luma stretched to
// full range, round((Y - 16) * 255 / 219) clamped to 0..255, which equals
// COLOR_BGR2GRAY of COLOR_YUV2BGR_YUYV's result within 1 grey level wherever that
// conversion does not clip a colour channel (tested): the chroma adds nothing to
// BT.601's luma, so the Y plane is the grey image without any colour conversion.
//
// Not thread-safe; one per tracker. The frame's pixels must outlive the calls
// for that frame (reset() keeps a header, not a copy).
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace dentar::ar {

// "" when `image` is a frame FrameGray takes (non-empty; CV_8UC3, CV_8UC2 with an
// even width, or CV_8UC1), else what is wrong with it.
std::string frame_gray_error(const cv::Mat& image);

// Grey levels of image(r) into gray (CV_8UC1, r.size()); r must lie inside the image.
void gray_of(const cv::Mat& image, const cv::Rect& r, cv::Mat& gray);

// A decimated grey copy of the whole frame: every k-th pixel of every k-th row
// (k >= 1; k = 1 is the whole grey frame). Reads only the pixels it keeps: the
// image-motion thumbnail's input at a cost that does not grow with the frame.
void decimated_gray(const cv::Mat& image, int k, cv::Mat& gray);

// BGR to YUYV 4:2:2 as a UVC camera sends it (BT.601, luma 16..235, chroma
// 16..240 averaged over each pixel pair): the camera's own format for tests and
// benches (OpenCV 4.6 converts YUYV to BGR but not back). bgr: CV_8UC3 with an
// even width; yuyv: CV_8UC2 of the same size.
void bgr_to_yuyv(const cv::Mat& bgr, cv::Mat& yuyv);

class FrameGray {
 public:
  // A new frame (see frame_gray_error for what is accepted; the caller checks).
  void reset(const cv::Mat& image);
  // The full-size grey image with at least `r` (clipped to the frame) valid;
  // pixels outside what was asked for this frame are stale.
  const cv::Mat& region(const cv::Rect& r);
  // The whole grey frame.
  const cv::Mat& whole();
  // The frame as given (BGR, YUYV or grey).
  const cv::Mat& image() const { return image_; }
  // Pixels converted this frame, as a fraction of the frame (0 for a grey frame:
  // nothing is converted).
  double converted_fraction() const;

 private:
  cv::Mat image_, gray_, own_;
  std::vector<cv::Rect> done_;
  bool all_ = false;
  double converted_px_ = 0;
};

}  // namespace dentar::ar
