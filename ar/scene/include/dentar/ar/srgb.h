// The sRGB transfer function (IEC 61966-2-1), decoding side: video grey
// levels are sRGB-encoded light (docs/conventions.md), the tracker and the
// footage generator's sensor model work in linear light. One definition for
// both (the generator must encode what the tracker decodes).
#pragma once

#include <opencv2/core/mat.hpp>

namespace dentar::ar {

// sRGB value in [0, 1] -> linear light in [0, 1].
double srgb_decode(double s);
// srgb_decode of the 8-bit codes i / 255 as a 1x256 CV_32F table for
// cv::LUT. Built on first use (thread-safe), shared, never to be written.
const cv::Mat& srgb_decode_table();

}  // namespace dentar::ar
