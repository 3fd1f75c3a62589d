// Motion JPEG decoding with TurboJPEG (libjpeg-turbo 2.1's tj* API). See mjpeg_decoder.h.
#include "dentar/ar/mjpeg_decoder.h"

#include <turbojpeg.h>

#include <cstdio>
#include <string>

namespace dentar::ar {
namespace {

constexpr int kMaxSide = 16384;

const char* subsampling_name(int s) {
  switch (s) {
    case TJSAMP_444: return "4:4:4";
    case TJSAMP_422: return "4:2:2";
    case TJSAMP_420: return "4:2:0";
    case TJSAMP_GRAY: return "grey";
    case TJSAMP_440: return "4:4:0";
    case TJSAMP_411: return "4:1:1";
    default: return "unknown";
  }
}

const char* colorspace_name(int c) {
  switch (c) {
    case TJCS_RGB: return "RGB";
    case TJCS_YCbCr: return "YCbCr";
    case TJCS_GRAY: return "grey";
    case TJCS_CMYK: return "CMYK";
    case TJCS_YCCK: return "YCCK";
    default: return "unknown";
  }
}

// One YUYV row from a luma row and the chroma row(s) of its JPEG, per horizontal
// chroma factor. The samples are mapped into the limited range on the way (the
// integer formulas of limited_luma / limited_chroma, written out so the loop
// vectorises).
inline std::uint8_t yl(unsigned v) { return static_cast<std::uint8_t>((v * 219u + 127u) / 255u + 16u); }
inline std::uint8_t cl(unsigned v) { return static_cast<std::uint8_t>((v * 224u + 4095u) / 255u); }

// Chroma at half the width (4:2:2, 4:2:0): sample p belongs to pixels 2p, 2p+1.
void pack_h2(const std::uint8_t* __restrict y, const std::uint8_t* __restrict u, const std::uint8_t* __restrict v,
             std::uint8_t* __restrict d, int pairs) {
  for (int p = 0; p < pairs; ++p) {
    d[4 * p] = yl(y[2 * p]);
    d[4 * p + 1] = cl(u[p]);
    d[4 * p + 2] = yl(y[2 * p + 1]);
    d[4 * p + 3] = cl(v[p]);
  }
}
// Chroma at full width (4:4:4, 4:4:0): the pair's mean, rounded.
void pack_h1(const std::uint8_t* __restrict y, const std::uint8_t* __restrict u, const std::uint8_t* __restrict v,
             std::uint8_t* __restrict d, int pairs) {
  for (int p = 0; p < pairs; ++p) {
    d[4 * p] = yl(y[2 * p]);
    d[4 * p + 1] = cl((u[2 * p] + u[2 * p + 1] + 1u) >> 1);
    d[4 * p + 2] = yl(y[2 * p + 1]);
    d[4 * p + 3] = cl((v[2 * p] + v[2 * p + 1] + 1u) >> 1);
  }
}
// Chroma at a quarter of the width (4:1:1): sample p/2 for pair p.
void pack_h4(const std::uint8_t* __restrict y, const std::uint8_t* __restrict u, const std::uint8_t* __restrict v,
             std::uint8_t* __restrict d, int pairs) {
  for (int p = 0; p < pairs; ++p) {
    d[4 * p] = yl(y[2 * p]);
    d[4 * p + 1] = cl(u[p >> 1]);
    d[4 * p + 2] = yl(y[2 * p + 1]);
    d[4 * p + 3] = cl(v[p >> 1]);
  }
}
// Grey JPEG: neutral chroma.
void pack_grey(const std::uint8_t* __restrict y, std::uint8_t* __restrict d, int pairs) {
  for (int p = 0; p < pairs; ++p) {
    d[4 * p] = yl(y[2 * p]);
    d[4 * p + 1] = 128;
    d[4 * p + 2] = yl(y[2 * p + 1]);
    d[4 * p + 3] = 128;
  }
}

}  // namespace

struct MjpegDecoder::Impl {
  tjhandle tj = nullptr;
  std::vector<std::uint8_t> y, u, v;  // the JPEG's planes (reused between frames)
  int subsamp = -1, colorspace = -1;   // of the last header read
  ~Impl() {
    if (tj != nullptr) tjDestroy(tj);
  }
  // A fresh decompressor after a failure: TurboJPEG 2.1 can leave the handle mid-header
  // (measured: after "Bogus Huffman table definition" every later good frame failed the
  // same way), so a damaged frame must not poison the next ones.
  void reset() {
    if (tj != nullptr) tjDestroy(tj);
    tj = tjInitDecompress();
  }
};

MjpegDecoder::MjpegDecoder(bool fast_dct) : impl_(std::make_unique<Impl>()), fast_dct_(fast_dct) {
  impl_->tj = tjInitDecompress();
}
MjpegDecoder::~MjpegDecoder() = default;
MjpegDecoder::MjpegDecoder(MjpegDecoder&&) noexcept = default;
MjpegDecoder& MjpegDecoder::operator=(MjpegDecoder&&) noexcept = default;

bool jpeg_has_end_marker(const std::uint8_t* data, std::size_t size) {
  if (data == nullptr) return false;
  std::size_t n = size;
  while (n > 0 && data[n - 1] == 0) --n;  // a driver's zero padding
  return n >= 4 && data[n - 2] == 0xFF && data[n - 1] == 0xD9;
}

bool MjpegDecoder::header(const std::uint8_t* data, std::size_t size, JpegHeader& h) {
  why_.clear();
  h = JpegHeader{};
  if (impl_->tj == nullptr) {
    why_ = std::string("TurboJPEG could not make a decompressor: ") + tjGetErrorStr2(nullptr);
    return false;
  }
  if (data == nullptr || size < 4) {
    why_ = "not a JPEG: " + std::to_string(size) + " bytes";
    return false;
  }
  if (data[0] != 0xFF || data[1] != 0xD8) {
    char b[96];
    std::snprintf(b, sizeof b, "not a JPEG: starts with 0x%02X 0x%02X, not the start-of-image marker FF D8", data[0],
                  data[1]);
    why_ = b;
    return false;
  }
  if (size > static_cast<std::size_t>(0x7fffffff)) {
    why_ = "JPEG of " + std::to_string(size) + " bytes: more than TurboJPEG takes";
    return false;
  }
  int w = 0, hh = 0, sub = -1, cs = -1;
  if (tjDecompressHeader3(impl_->tj, data, static_cast<unsigned long>(size), &w, &hh, &sub, &cs) != 0) {
    why_ = std::string("bad JPEG header: ") + tjGetErrorStr2(impl_->tj);
    impl_->reset();
    return false;
  }
  impl_->subsamp = sub;
  impl_->colorspace = cs;
  h.width = w;
  h.height = hh;
  h.subsampling = subsampling_name(sub);
  h.colorspace = colorspace_name(cs);
  if (w <= 0 || hh <= 0 || w > kMaxSide || hh > kMaxSide) {
    why_ = "JPEG of " + std::to_string(w) + "x" + std::to_string(hh) + " px: sides must be in 1.." +
           std::to_string(kMaxSide);
    return false;
  }
  return true;
}

bool MjpegDecoder::decode(const cv::Mat& bytes, MjpegOutput output, cv::Mat& out) {
  if (bytes.empty() || bytes.type() != CV_8UC1 || !bytes.isContinuous() || (bytes.rows != 1 && bytes.cols != 1)) {
    out = cv::Mat();
    why_ = "JPEG bytes must be one continuous row or column of CV_8UC1 (got " + cv::typeToString(bytes.type()) + " " +
           std::to_string(bytes.cols) + "x" + std::to_string(bytes.rows) + ")";
    return false;
  }
  return decode(bytes.data, bytes.total(), output, out);
}

bool MjpegDecoder::check(const std::uint8_t* data, std::size_t size) {
  // A frame cut short on the bus (checked first: a cut inside the header is a truncation too).
  if (data != nullptr && size >= 2 && data[0] == 0xFF && data[1] == 0xD8 && !jpeg_has_end_marker(data, size)) {
    why_ = "truncated JPEG: no end-of-image marker (FF D9) after " + std::to_string(size) + " bytes";
    return false;
  }
  if (!header(data, size, header_)) return false;
  if (expect_w_ > 0 && (header_.width != expect_w_ || header_.height != expect_h_)) {
    why_ = "JPEG of " + std::to_string(header_.width) + "x" + std::to_string(header_.height) + " px in a stream of " +
           std::to_string(expect_w_) + "x" + std::to_string(expect_h_) + " (a damaged header?)";
    return false;
  }
  return true;
}

bool MjpegDecoder::check(const cv::Mat& bytes) {
  if (bytes.empty() || bytes.type() != CV_8UC1 || !bytes.isContinuous() || (bytes.rows != 1 && bytes.cols != 1)) {
    why_ = "JPEG bytes must be one continuous row or column of CV_8UC1 (got " + cv::typeToString(bytes.type()) + " " +
           std::to_string(bytes.cols) + "x" + std::to_string(bytes.rows) + ")";
    return false;
  }
  return check(bytes.data, bytes.total());
}

bool MjpegDecoder::decode(const std::uint8_t* data, std::size_t size, MjpegOutput output, cv::Mat& out) {
  if (!check(data, size)) {
    out = cv::Mat();
    return false;
  }
  const int w = header_.width, h = header_.height;
  const int sub = impl_->subsamp, cs = impl_->colorspace;
  const int flags = fast_dct_ ? TJFLAG_FASTDCT : 0;
  const bool planes = output == MjpegOutput::kYuyv && (cs == TJCS_YCbCr || cs == TJCS_GRAY) && w % 2 == 0 &&
                      sub >= TJSAMP_444 && sub <= TJSAMP_411;
  int r = 0;
  if (planes) {
    const bool grey = sub == TJSAMP_GRAY;
    // Planes as TurboJPEG lays them out: each padded to whole MCUs (a 4:2:0 luma plane of odd
    // height has one more row, a 4:1:1 one up to 3 more columns).
    const int yw = tjPlaneWidth(0, w, sub), yh = tjPlaneHeight(0, h, sub);
    const int cw = grey ? 0 : tjPlaneWidth(1, w, sub), ch = grey ? 0 : tjPlaneHeight(1, h, sub);
    if (yw < w || yh < h || (!grey && (cw <= 0 || ch <= 0))) {
      out = cv::Mat();
      why_ = "JPEG planes of an unexpected size for " + header_.subsampling;
      return false;
    }
    impl_->y.resize(static_cast<std::size_t>(yw) * static_cast<std::size_t>(yh));
    impl_->u.resize(static_cast<std::size_t>(cw) * static_cast<std::size_t>(ch));
    impl_->v.resize(impl_->u.size());
    unsigned char* dst[3] = {impl_->y.data(), grey ? nullptr : impl_->u.data(), grey ? nullptr : impl_->v.data()};
    int strides[3] = {yw, cw, cw};
    r = tjDecompressToYUVPlanes(impl_->tj, data, static_cast<unsigned long>(size), dst, w, strides, h, flags);
    if (r == 0 || tjGetErrorCode(impl_->tj) == TJERR_WARNING) {
      out.create(h, w, CV_8UC2);
      const int pairs = w / 2;
      const int vshift = (sub == TJSAMP_420 || sub == TJSAMP_440) ? 1 : 0;
      for (int row = 0; row < h; ++row) {
        const std::uint8_t* yr = impl_->y.data() + static_cast<std::size_t>(row) * static_cast<std::size_t>(yw);
        std::uint8_t* d = out.ptr<std::uint8_t>(row);
        if (grey) {
          pack_grey(yr, d, pairs);
          continue;
        }
        const std::size_t co = static_cast<std::size_t>(row >> vshift) * static_cast<std::size_t>(cw);
        const std::uint8_t* ur = impl_->u.data() + co;
        const std::uint8_t* vr = impl_->v.data() + co;
        if (sub == TJSAMP_422 || sub == TJSAMP_420)
          pack_h2(yr, ur, vr, d, pairs);
        else if (sub == TJSAMP_411)
          pack_h4(yr, ur, vr, d, pairs);
        else
          pack_h1(yr, ur, vr, d, pairs);
      }
    }
  } else {
    out.create(h, w, CV_8UC3);
    r = tjDecompress2(impl_->tj, data, static_cast<unsigned long>(size), out.data, w, static_cast<int>(out.step[0]), h,
                      TJPF_BGR, flags);
  }
  if (r != 0) {
    const std::string msg = tjGetErrorStr2(impl_->tj);
    if (tjGetErrorCode(impl_->tj) == TJERR_WARNING && msg.find("extraneous bytes") != std::string::npos) {
      ++warnings_kept_;  // a UVC camera's padding before EOI: the picture is whole
      return true;
    }
    out = cv::Mat();
    why_ = std::string(tjGetErrorCode(impl_->tj) == TJERR_WARNING ? "corrupt JPEG data: " : "JPEG does not decode: ") +
           msg;
    impl_->reset();
    return false;
  }
  return true;
}

}  // namespace dentar::ar
