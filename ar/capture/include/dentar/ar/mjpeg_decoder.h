// Motion JPEG decoding for the live sources (issue 28, session 18): one camera
// frame's JPEG bytes decoded with libjpeg-turbo's TurboJPEG API directly, not
// through cv::imdecode.
//
// Outputs (MjpegOutput):
//   kBgr   CV_8UC3 BGR, decoded by libjpeg-turbo straight into the frame's buffer
//          (the same samples as cv::imdecode of the same bytes: same library,
//          same accurate integer IDCT and "fancy" chroma upsampling; tested);
//   kYuyv  CV_8UC2 YUYV 4:2:2 (Y0 U Y1 V, ITU-R BT.601 limited range, luma
//          16..235, chroma 16..240: the layout a YUYV camera delivers, frame_source.h),
//          from the JPEG's own Y'CbCr planes without any colour conversion
//          or upsampling: the JPEG's full-range samples are mapped into the
//          limited range (one integer formula per sample, limited_luma /
//          limited_chroma below) and its chroma is taken at 4:2:2 (4:2:2 as
//          it is; 4:2:0 each chroma row for two image rows; 4:4:4 and 4:4:0 the
//          mean of a pixel pair; 4:1:1 each chroma sample for two pairs; grey
//          U = V = 128). The tracker then reads luma from it and the compositor
//          converts only what it draws, as for a YUYV camera. A JPEG that is
//          not Y'CbCr or grey (RGB, CMYK), or of odd width, is decoded to BGR
//          instead (the caller checks Mat::type()).
// fast_dct: libjpeg-turbo's fast integer IDCT (TJFLAG_FASTDCT) instead of the
// accurate one: faster, less exact (docs/BENCHMARKS.md, session 18, gives both).
//
// Bad input (a camera's corrupt or truncated frame): decode() returns false and
// why() names what is wrong (libjpeg's message, or "truncated: no end-of-image
// marker"); the frame is for the caller to drop and count. A JPEG that libjpeg
// decodes with a warning is refused too (corrupt entropy data, a premature end:
// the picture is partly grey), except for the one warning that many UVC cameras
// raise on every good frame, "extraneous bytes before marker" (padding after
// the entropy-coded data): that frame is kept and counted in warnings_kept().
// Never throws, never aborts on any input; sizes above 16384 px a side are refused
// before any buffer is made.
//
// Thread: one decoder per thread (it owns a TurboJPEG handle and its buffers).
// Buffers are reused between frames of one size; the output Mat is made anew for
// every frame unless the caller hands one that no one else holds (Mat::create).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

namespace dentar::ar {

enum class MjpegOutput { kBgr, kYuyv };

// The header of one JPEG: size, chroma subsampling ("4:2:2", "4:2:0", "4:4:4",
// "4:4:0", "4:1:1", "grey", "unknown") and colour space ("YCbCr", "grey", "RGB",
// "CMYK", "YCCK").
struct JpegHeader {
  int width = 0, height = 0;
  std::string subsampling, colorspace;
};

class MjpegDecoder {
 public:
  explicit MjpegDecoder(bool fast_dct = false);
  ~MjpegDecoder();
  MjpegDecoder(MjpegDecoder&&) noexcept;
  MjpegDecoder& operator=(MjpegDecoder&&) noexcept;
  MjpegDecoder(const MjpegDecoder&) = delete;
  MjpegDecoder& operator=(const MjpegDecoder&) = delete;

  // Decodes `size` bytes at `data` into `out` (see the outputs above). false:
  // the frame is refused, `out` is left empty and why() says why.
  bool decode(const std::uint8_t* data, std::size_t size, MjpegOutput output, cv::Mat& out);
  bool decode(const cv::Mat& bytes, MjpegOutput output, cv::Mat& out);  // 1xN / Nx1 CV_8UC1
  // The checks decode() makes before any pixel, without decoding: the start and
  // end-of-image markers, the header, and the expected size (expect_size). A frame
  // that passes can still fail decode() (corrupt entropy data); one that fails
  // would fail decode() with the same why(). Costs a header parse (microseconds).
  bool check(const std::uint8_t* data, std::size_t size);
  bool check(const cv::Mat& bytes);  // 1xN / Nx1 CV_8UC1
  // Only the header (no pixels). false on a header that does not parse (why()).
  bool header(const std::uint8_t* data, std::size_t size, JpegHeader& h);

  // A stream's frames all have one size: once set (a live source sets it from its
  // first frame), a JPEG whose header announces another size is refused before any
  // pixel is decoded (a damaged header cannot make it decode 16384 x 16384 px).
  // 0, 0: any size up to 16384 px a side.
  void expect_size(int width, int height) { expect_w_ = width, expect_h_ = height; }

  const std::string& why() const { return why_; }
  const JpegHeader& last_header() const { return header_; }
  std::int64_t warnings_kept() const { return warnings_kept_; }
  bool fast_dct() const { return fast_dct_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool fast_dct_ = false;
  std::string why_;
  JpegHeader header_;
  std::int64_t warnings_kept_ = 0;
  int expect_w_ = 0, expect_h_ = 0;
};

// True when the bytes end with the JPEG end-of-image marker (FF D9), allowing
// trailing zero bytes (some UVC drivers pad the buffer). A camera frame without
// it was cut short on the bus.
bool jpeg_has_end_marker(const std::uint8_t* data, std::size_t size);

// The full-range (JPEG/JFIF) to limited-range (BT.601) mapping of one sample,
// rounded: luma 0..255 -> 16..235, chroma 0..255 -> 16..240 (128 stays 128).
inline std::uint8_t limited_luma(unsigned y) { return static_cast<std::uint8_t>((y * 219u + 127u) / 255u + 16u); }
inline std::uint8_t limited_chroma(unsigned c) { return static_cast<std::uint8_t>((c * 224u + 3968u + 127u) / 255u); }

}  // namespace dentar::ar
