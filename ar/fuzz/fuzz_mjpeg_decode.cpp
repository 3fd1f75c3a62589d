// Fuzz target: MjpegDecoder (ar/capture, issue 28 session 18), the Motion JPEG bytes
// a camera sends, to BGR and to YUYV, accurate and fast IDCT.
//
// Every input must be decoded or refused with a reason, never crash. A decoded frame
// has the header's size and the output's type (YUYV only for an even width), and
// YUYV samples lie in the limited range (luma 16..235, chroma 16..240). Headers of
// more than 1 Mpx are refused through expect_size, as a live source refuses a frame
// of another size (decoding a damaged 16384 x 16384 header would only cost time).
#include <cstdint>
#include <cstdio>
#include <opencv2/core/mat.hpp>

#include "dentar/ar/mjpeg_decoder.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dentar::ar;
  static MjpegDecoder accurate(false), fast(true);
  JpegHeader h;
  const bool parsed = accurate.header(data, size, h);
  if (!parsed && accurate.why().empty()) __builtin_trap();
  const bool small = parsed && static_cast<long long>(h.width) * h.height <= (1 << 20);
  for (MjpegDecoder* d : {&accurate, &fast}) {
    d->expect_size(small ? h.width : 1, small ? h.height : 1);
    for (MjpegOutput o : {MjpegOutput::kBgr, MjpegOutput::kYuyv}) {
      cv::Mat out;
      if (!d->decode(data, size, o, out)) {
        if (d->why().empty() || !out.empty()) __builtin_trap();
        continue;
      }
      if (!small || out.cols != h.width || out.rows != h.height) __builtin_trap();
      if (out.type() == CV_8UC2) {
        if (o != MjpegOutput::kYuyv || out.cols % 2 != 0) __builtin_trap();
        for (int r = 0; r < out.rows; ++r) {
          const std::uint8_t* p = out.ptr<std::uint8_t>(r);
          for (int c = 0; c < out.cols; ++c) {
            if (p[2 * c] < 16 || p[2 * c] > 235 || p[2 * c + 1] < 16 || p[2 * c + 1] > 240) __builtin_trap();
          }
        }
      } else if (out.type() != CV_8UC3) {
        __builtin_trap();
      }
    }
  }
  return 0;
}
