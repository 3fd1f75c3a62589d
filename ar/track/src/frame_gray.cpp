#include "dentar/ar/frame_gray.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace dentar::ar {
namespace {

// BT.601 luma (16..235) to full-range grey, rounded and clamped.
const std::array<std::uint8_t, 256>& luma_lut() {
  static const std::array<std::uint8_t, 256> lut = [] {
    std::array<std::uint8_t, 256> t{};
    for (int y = 0; y < 256; ++y)
      t[static_cast<std::size_t>(y)] =
          static_cast<std::uint8_t>(std::clamp(std::lround((y - 16) * 255.0 / 219.0), 0L, 255L));
    return t;
  }();
  return lut;
}

}  // namespace

std::string frame_gray_error(const cv::Mat& image) {
  if (image.empty()) return "the frame is empty";
  if (image.depth() != CV_8U || image.channels() < 1 || image.channels() > 3)
    return "frame type " + cv::typeToString(image.type()) +
           " is neither CV_8UC3 (BGR), CV_8UC2 (YUYV) nor CV_8UC1 (grey)";
  if (image.channels() == 2 && image.cols % 2 != 0)
    return "a YUYV frame (CV_8UC2) must have an even width (it is " + std::to_string(image.cols) + " px)";
  return "";
}

void gray_of(const cv::Mat& image, const cv::Rect& r, cv::Mat& gray) {
  const cv::Mat src = image(r);
  switch (image.channels()) {
    case 3:
      cv::cvtColor(src, gray, cv::COLOR_BGR2GRAY);
      break;
    case 2: {
      gray.create(r.size(), CV_8UC1);
      const auto& lut = luma_lut();
      for (int y = 0; y < r.height; ++y) {
        const std::uint8_t* s = src.ptr<std::uint8_t>(y);
        std::uint8_t* d = gray.ptr<std::uint8_t>(y);
        for (int x = 0; x < r.width; ++x) d[x] = lut[s[2 * x]];
      }
      break;
    }
    default:
      src.copyTo(gray);
  }
}

void decimated_gray(const cv::Mat& image, int k, cv::Mat& gray) {
  k = std::max(1, k);
  if (k == 1) {
    gray_of(image, cv::Rect(0, 0, image.cols, image.rows), gray);
    return;
  }
  const int w = image.cols / k, h = image.rows / k;
  gray.create(h, w, CV_8UC1);
  const int ch = image.channels();
  if (ch == 3) {  // OpenCV's BGR2GRAY weights (14-bit fixed point, rounded)
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* s = image.ptr<std::uint8_t>(y * k);
      std::uint8_t* d = gray.ptr<std::uint8_t>(y);
      for (int x = 0; x < w; ++x) {
        const std::uint8_t* p = s + 3 * k * x;
        d[x] = static_cast<std::uint8_t>((p[0] * 1868 + p[1] * 9617 + p[2] * 4899 + (1 << 13)) >> 14);
      }
    }
  } else {  // YUYV: a pixel's own luma is its channel 0 wherever it is picked; grey: itself
    const auto& lut = luma_lut();
    for (int y = 0; y < h; ++y) {
      const std::uint8_t* s = image.ptr<std::uint8_t>(y * k);
      std::uint8_t* d = gray.ptr<std::uint8_t>(y);
      if (ch == 2)
        for (int x = 0; x < w; ++x) d[x] = lut[s[2 * k * x]];
      else
        for (int x = 0; x < w; ++x) d[x] = s[k * x];
    }
  }
}

void bgr_to_yuyv(const cv::Mat& bgr, cv::Mat& yuyv) {
  CV_Assert(bgr.type() == CV_8UC3 && bgr.cols % 2 == 0);
  yuyv.create(bgr.size(), CV_8UC2);
  auto u8 = [](double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L)); };
  for (int y = 0; y < bgr.rows; ++y) {
    const std::uint8_t* s = bgr.ptr<std::uint8_t>(y);
    std::uint8_t* d = yuyv.ptr<std::uint8_t>(y);
    for (int x = 0; x < bgr.cols; x += 2) {
      double U = 0, V = 0;
      for (int i = 0; i < 2; ++i) {
        const double B = s[3 * (x + i)], G = s[3 * (x + i) + 1], R = s[3 * (x + i) + 2];
        d[2 * (x + i)] = u8(16 + (65.481 * R + 128.553 * G + 24.966 * B) / 255);
        U += 128 + (-37.797 * R - 74.203 * G + 112.0 * B) / 255;
        V += 128 + (112.0 * R - 93.786 * G - 18.214 * B) / 255;
      }
      d[2 * x + 1] = u8(U / 2);
      d[2 * x + 3] = u8(V / 2);
    }
  }
}

void FrameGray::reset(const cv::Mat& image) {
  image_ = image;
  done_.clear();
  converted_px_ = 0;
  all_ = image.channels() == 1;
  if (all_) {
    gray_ = image;
    return;
  }
  // A buffer of our own (never the caller's grey frame of a previous call).
  own_.create(image.size(), CV_8UC1);
  gray_ = own_;
}

const cv::Mat& FrameGray::region(const cv::Rect& r_in) {
  if (all_) return gray_;
  const cv::Rect r = r_in & cv::Rect(0, 0, image_.cols, image_.rows);
  if (r.empty()) return gray_;
  for (const cv::Rect& d : done_)
    if ((d & r) == r) return gray_;
  cv::Mat dst = gray_(r);
  gray_of(image_, r, dst);
  done_.push_back(r);
  converted_px_ += r.area();
  return gray_;
}

const cv::Mat& FrameGray::whole() {
  if (all_) return gray_;
  cv::Mat dst = gray_;
  gray_of(image_, cv::Rect(0, 0, image_.cols, image_.rows), dst);
  all_ = true;
  converted_px_ += image_.total();
  return gray_;
}

double FrameGray::converted_fraction() const {
  return image_.empty() ? 0.0 : converted_px_ / static_cast<double>(image_.total());
}

}  // namespace dentar::ar
