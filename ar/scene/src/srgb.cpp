#include "dentar/ar/srgb.h"

#include <cmath>

namespace dentar::ar {

double srgb_decode(double s) { return s <= 0.04045 ? s / 12.92 : std::pow((s + 0.055) / 1.055, 2.4); }

const cv::Mat& srgb_decode_table() {
  static const cv::Mat t = [] {
    cv::Mat m(1, 256, CV_32F);
    for (int i = 0; i < 256; ++i) m.at<float>(0, i) = static_cast<float>(srgb_decode(i / 255.0));
    return m;
  }();
  return t;
}

}  // namespace dentar::ar
