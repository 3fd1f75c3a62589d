// MjpegDecoder (issue 28, session 18): TurboJPEG straight to BGR gives exactly
// cv::imdecode's pixels; to YUYV it keeps the JPEG's own samples in the limited
// range; a camera's corrupt or truncated frames are refused with a reason (never
// a crash), and through a live stand-in they are counted drops.
#include "dentar/ar/mjpeg_decoder.h"

#include <gtest/gtest.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "dentar/ar/frame_source.h"

namespace dentar::ar {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

// A camera-like picture: smooth shading, saturated colour patches, black-and-white
// squares (tag-like edges) and sensor noise.
cv::Mat scene(int w, int h, int seed) {
  cv::Mat img(h, w, CV_8UC3);
  cv::RNG rng(static_cast<std::uint64_t>(seed) * 7919u + 1u);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uchar>(60 + 120 * x / std::max(1, w)),
                                          static_cast<uchar>(90 + 100 * y / std::max(1, h)),
                                          static_cast<uchar>(150 - 80 * (x + y) / std::max(1, w + h)));
  for (int k = 0; k < 12; ++k) {
    const cv::Point p(rng.uniform(0, w), rng.uniform(0, h));
    const int s = std::max(2, rng.uniform(2, std::max(3, w / 6)));
    cv::rectangle(img, cv::Rect(p.x, p.y, s, s),
                  k % 3 == 0 ? cv::Scalar(0, 0, 0)
                             : k % 3 == 1 ? cv::Scalar(255, 255, 255)
                                          : cv::Scalar(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256)),
                  cv::FILLED);
  }
  cv::Mat noise(h, w, CV_8UC3);
  rng.fill(noise, cv::RNG::NORMAL, 0, 4);
  cv::add(img, noise, img);
  return img;
}

// JPEG bytes of a BGR picture at a chroma subsampling (TJSAMP_*), as a camera
// would send them (TurboJPEG's encoder, the test's only use of it).
Bytes encode(const cv::Mat& bgr, int subsamp, int quality = 85) {
  tjhandle h = tjInitCompress();
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  cv::Mat src = bgr;
  int pf = TJPF_BGR;
  if (subsamp == TJSAMP_GRAY) {
    cv::cvtColor(bgr, src, cv::COLOR_BGR2GRAY);
    pf = TJPF_GRAY;
  }
  const int r = tjCompress2(h, src.data, src.cols, static_cast<int>(src.step[0]), src.rows, pf, &buf, &size, subsamp,
                            quality, 0);
  Bytes out;
  if (r == 0) out.assign(buf, buf + size);
  tjFree(buf);
  tjDestroy(h);
  return out;
}

cv::Mat imdecode(const Bytes& b) { return cv::imdecode(b, cv::IMREAD_COLOR); }

TEST(MjpegDecoder, RangeMappingIsTheRoundedFormula) {
  for (unsigned v = 0; v < 256; ++v) {
    EXPECT_EQ(limited_luma(v), std::lround(16 + v * 219.0 / 255.0)) << v;
    EXPECT_EQ(limited_chroma(v), std::lround(128 + (v - 128.0) * 224.0 / 255.0)) << v;
  }
}

// The BGR output is cv::imdecode's to the last bit (same library, same IDCT and
// upsampling), for every subsampling a camera uses and for odd sizes.
TEST(MjpegDecoder, BgrIsImdecodeExactly) {
  MjpegDecoder d;
  const int subs[] = {TJSAMP_444, TJSAMP_422, TJSAMP_420, TJSAMP_440, TJSAMP_411, TJSAMP_GRAY};
  for (const cv::Size sz : {cv::Size(640, 480), cv::Size(33, 17), cv::Size(2, 1)}) {
    for (int s : subs) {
      SCOPED_TRACE(std::to_string(sz.width) + "x" + std::to_string(sz.height) + " subsampling " + std::to_string(s));
      const Bytes j = encode(scene(sz.width, sz.height, s), s);
      ASSERT_FALSE(j.empty());
      cv::Mat got;
      ASSERT_TRUE(d.decode(j.data(), j.size(), MjpegOutput::kBgr, got)) << d.why();
      const cv::Mat want = imdecode(j);
      ASSERT_EQ(got.type(), CV_8UC3);
      ASSERT_EQ(got.size(), want.size());
      EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0);
    }
  }
  EXPECT_EQ(d.warnings_kept(), 0);
}

// YUYV from the JPEG's planes: a grey JPEG's luma is exactly the limited-range
// mapping of imdecode's grey and its chroma neutral; a colour JPEG converted back
// (OpenCV's YUYV conversion, as the compositor and the recorder use) stays close
// to imdecode's BGR: the range mapping's rounding, and chroma taken at 4:2:2
// without libjpeg's smoothing upsampler, differ only at colour edges.
TEST(MjpegDecoder, YuyvKeepsTheJpegsOwnSamples) {
  MjpegDecoder d;
  {
    const Bytes j = encode(scene(64, 48, 1), TJSAMP_GRAY);
    cv::Mat y;
    ASSERT_TRUE(d.decode(j.data(), j.size(), MjpegOutput::kYuyv, y)) << d.why();
    ASSERT_EQ(y.type(), CV_8UC2);
    cv::Mat grey;
    cv::cvtColor(imdecode(j), grey, cv::COLOR_BGR2GRAY);
    for (int r = 0; r < y.rows; ++r)
      for (int c = 0; c < y.cols; ++c) {
        ASSERT_EQ(y.at<cv::Vec2b>(r, c)[0], limited_luma(grey.at<uchar>(r, c))) << r << "," << c;
        ASSERT_EQ(y.at<cv::Vec2b>(r, c)[1], 128);
      }
  }
  for (int s : {TJSAMP_444, TJSAMP_422, TJSAMP_420, TJSAMP_440, TJSAMP_411}) {
    SCOPED_TRACE("subsampling " + std::to_string(s));
    const Bytes j = encode(scene(640, 480, s + 10), s);
    cv::Mat y, back;
    ASSERT_TRUE(d.decode(j.data(), j.size(), MjpegOutput::kYuyv, y)) << d.why();
    ASSERT_EQ(y.type(), CV_8UC2);
    ASSERT_EQ(y.size(), cv::Size(640, 480));
    EXPECT_EQ(d.last_header().colorspace, "YCbCr");
    cv::cvtColor(y, back, cv::COLOR_YUV2BGR_YUYV);
    cv::Mat diff;
    cv::absdiff(back, imdecode(j), diff);
    const double mean = cv::mean(diff.reshape(1))[0];
    std::printf("[ yuyv ] subsampling %d: |BGR(yuyv) - imdecode| mean %.3f, max %.0f\n", s, mean,
                cv::norm(diff, cv::NORM_INF));
    EXPECT_LT(mean, 2.0);
    // The samples themselves: luma is the JPEG's Y plane mapped, pixel for pixel; at
    // 4:2:2 chroma is its Cb/Cr planes mapped, sample for sample.
    tjhandle h = tjInitDecompress();
    const int cw = tjPlaneWidth(1, 640, s), ch = tjPlaneHeight(1, 480, s);
    std::vector<std::uint8_t> py(640 * 480), pu(static_cast<std::size_t>(cw * ch)), pv(pu.size());
    unsigned char* planes[3] = {py.data(), pu.data(), pv.data()};
    int strides[3] = {640, cw, cw};
    ASSERT_EQ(tjDecompressToYUVPlanes(h, j.data(), j.size(), planes, 640, strides, 480, 0), 0);
    tjDestroy(h);
    int luma_off = 0, chroma_off = 0;
    for (int r = 0; r < 480; ++r)
      for (int c = 0; c < 640; ++c) {
        const cv::Vec2b v = y.at<cv::Vec2b>(r, c);
        luma_off += v[0] != limited_luma(py[static_cast<std::size_t>(r * 640 + c)]);
        if (s == TJSAMP_422) {
          const auto& plane = c % 2 == 0 ? pu : pv;
          chroma_off += v[1] != limited_chroma(plane[static_cast<std::size_t>(r * cw + c / 2)]);
        }
      }
    EXPECT_EQ(luma_off, 0);
    EXPECT_EQ(chroma_off, 0);
  }
  // Odd width: no YUYV layout; BGR instead (the caller checks the type).
  const Bytes odd = encode(scene(33, 17, 3), TJSAMP_422);
  cv::Mat o;
  ASSERT_TRUE(d.decode(odd.data(), odd.size(), MjpegOutput::kYuyv, o)) << d.why();
  EXPECT_EQ(o.type(), CV_8UC3);
}

TEST(MjpegDecoder, FastDctIsCloseAndSaysSo) {
  MjpegDecoder fast(true);
  EXPECT_TRUE(fast.fast_dct());
  const Bytes j = encode(scene(320, 240, 4), TJSAMP_422);
  cv::Mat got;
  ASSERT_TRUE(fast.decode(j.data(), j.size(), MjpegOutput::kBgr, got)) << fast.why();
  cv::Mat diff;
  cv::absdiff(got, imdecode(j), diff);
  EXPECT_LT(cv::mean(diff.reshape(1))[0], 2.0);
}

// A camera's damaged frames: every cut of a frame, bit flips, garbage and absurd
// headers are refused with a reason (or decode, when a flip lands harmlessly), and
// never crash. A cut frame is named as truncated.
TEST(MjpegDecoder, CorruptAndTruncatedFramesAreRefusedWithAReason) {
  MjpegDecoder d;
  const Bytes good = encode(scene(160, 120, 5), TJSAMP_422);
  cv::Mat out;
  for (MjpegOutput o : {MjpegOutput::kBgr, MjpegOutput::kYuyv}) {
    for (std::size_t cut = 0; cut < good.size(); cut += std::max<std::size_t>(1, good.size() / 97)) {
      EXPECT_FALSE(d.decode(good.data(), cut, o, out)) << "cut at " << cut;
      EXPECT_FALSE(d.why().empty());
      EXPECT_TRUE(out.empty());
      if (cut > 200) {
        EXPECT_NE(d.why().find("truncated"), std::string::npos) << d.why();
      }
    }
    // Bit flips anywhere (headers, tables, entropy data): no crash; a refusal has a reason.
    cv::RNG rng(7);
    int refused = 0;
    for (int k = 0; k < 300; ++k) {
      Bytes b = good;
      for (int f = 0; f < 1 + k % 4; ++f) b[static_cast<std::size_t>(rng.uniform(0, static_cast<int>(b.size())))] ^=
          static_cast<std::uint8_t>(1u << rng.uniform(0, 8));
      const bool ok = d.decode(b.data(), b.size(), o, out);
      if (!ok) {
        ++refused;
        EXPECT_FALSE(d.why().empty());
      } else {
        EXPECT_EQ(out.cols, 160);
      }
    }
    EXPECT_GT(refused, 30);
  }
  // Not JPEG at all, empty, null.
  const Bytes junk = {0x12, 0x34, 0x56, 0x78, 0x9a, 0xff, 0xd9};
  EXPECT_FALSE(d.decode(junk.data(), junk.size(), MjpegOutput::kBgr, out));
  EXPECT_NE(d.why().find("start-of-image"), std::string::npos) << d.why();
  EXPECT_FALSE(d.decode(nullptr, 0, MjpegOutput::kBgr, out));
  EXPECT_FALSE(d.decode(cv::Mat(), MjpegOutput::kBgr, out));
  // A header announcing 60000 x 60000 px: refused before any buffer is made.
  Bytes huge = good;
  for (std::size_t i = 0; i + 8 < huge.size(); ++i)
    if (huge[i] == 0xFF && huge[i + 1] == 0xC0) {  // SOF0: length(2) precision(1) height(2) width(2)
      huge[i + 5] = 0xEA, huge[i + 6] = 0x60, huge[i + 7] = 0xEA, huge[i + 8] = 0x60;
      break;
    }
  EXPECT_FALSE(d.decode(huge.data(), huge.size(), MjpegOutput::kYuyv, out));
  EXPECT_NE(d.why().find("60000x60000"), std::string::npos) << d.why();
  // The decoder still decodes a good frame after all that.
  ASSERT_TRUE(d.decode(good.data(), good.size(), MjpegOutput::kBgr, out)) << d.why();
  EXPECT_EQ(cv::norm(out, imdecode(good), cv::NORM_INF), 0.0);
}

// Padding after the entropy-coded data (many UVC cameras): libjpeg warns of
// "extraneous bytes"; the picture is whole, so it is kept and counted. Zero bytes
// after the end-of-image marker (a driver's buffer) are not a truncation.
TEST(MjpegDecoder, ExtraneousBytesAndTrailingPaddingAreKept) {
  MjpegDecoder d;
  const Bytes good = encode(scene(96, 64, 6), TJSAMP_420);
  const cv::Mat want = imdecode(good);
  Bytes padded = good;
  padded.insert(padded.end() - 2, {0x00, 0x00, 0x00});  // before FF D9
  cv::Mat out;
  ASSERT_TRUE(d.decode(padded.data(), padded.size(), MjpegOutput::kBgr, out)) << d.why();
  EXPECT_EQ(d.warnings_kept(), 1);
  EXPECT_EQ(cv::norm(out, want, cv::NORM_INF), 0.0);
  Bytes tail = good;
  tail.insert(tail.end(), 100, 0x00);
  ASSERT_TRUE(d.decode(tail.data(), tail.size(), MjpegOutput::kBgr, out)) << d.why();
  EXPECT_EQ(cv::norm(out, want, cv::NORM_INF), 0.0);
}

// Through a live stand-in (the camera reader as it runs): corrupt and cut frames
// among good ones are skipped, each counted as a dropped frame and as corrupt with
// its reason; the good ones arrive as YUYV with their own JPEG bytes.
TEST(MjpegDecoder, LiveStandInCountsCorruptFramesAsDrops) {
  const fs::path dir = fs::temp_directory_path() / "dentar_mjpeg_live";
  fs::create_directories(dir);
  std::vector<Bytes> frames;
  for (int i = 0; i < 12; ++i) frames.push_back(encode(scene(320, 240, 20 + i), TJSAMP_422));
  frames[3].resize(frames[3].size() / 2);                            // cut short on the bus
  std::fill(frames[6].begin() + 2, frames[6].begin() + 40, 0x55);    // header destroyed (SOI kept)
  frames[9] = Bytes(frames[9].size(), 0xAB);                         // garbage
  const fs::path avi = dir / "cam.avi";
  ASSERT_TRUE(write_mjpeg_avi(avi.string(), frames, 320, 240, 60).ok());
  FrameSourceOptions so;
  so.pixel_format = "native";
  auto src = FrameSource::open("live:" + avi.string(), so);
  ASSERT_TRUE(src.ok()) << src.error();
  EXPECT_NE((*src)->description().find("MJPG decoded to YUYV"), std::string::npos) << (*src)->description();
  int good = 0, dropped = 0;
  Frame f;
  for (;;) {
    auto r = (*src)->read(f);
    ASSERT_TRUE(r.ok()) << r.error();
    if (!*r) break;
    ++good;
    dropped += f.dropped_before;
    EXPECT_EQ(f.image.type(), CV_8UC2);
    EXPECT_FALSE(f.encoded.empty());
  }
  EXPECT_EQ((*src)->corrupt_total(), 3);
  EXPECT_FALSE((*src)->last_corrupt().empty());
  std::printf("[ live ] %d good frames, %d dropped before them, %lld dropped in all; last corrupt: %s\n", good,
              dropped, static_cast<long long>((*src)->dropped_total()), (*src)->last_corrupt().c_str());
  // Paced at 60 fps on a loaded machine the reader may also skip good frames it was
  // late for; the three corrupt ones are always among the drops.
  EXPECT_EQ(good + (*src)->dropped_total(), 12);
  EXPECT_GE((*src)->dropped_total(), 3);
  fs::remove_all(dir);
}

// Eleven corrupt frames in a row: the stream ends with an error naming the reason.
TEST(MjpegDecoder, LiveStandInOfOnlyCorruptFramesIsAnError) {
  const fs::path dir = fs::temp_directory_path() / "dentar_mjpeg_bad";
  fs::create_directories(dir);
  std::vector<Bytes> frames(1, encode(scene(64, 48, 1), TJSAMP_422));
  for (int i = 0; i < 14; ++i) {
    Bytes b = frames[0];
    b.resize(b.size() / 3);
    frames.push_back(b);
  }
  const fs::path avi = dir / "cam.avi";
  ASSERT_TRUE(write_mjpeg_avi(avi.string(), frames, 64, 48, 30).ok());
  auto src = FrameSource::open("live:" + avi.string(), {});
  ASSERT_TRUE(src.ok()) << src.error();
  Frame f;
  auto r = (*src)->read(f);
  ASSERT_TRUE(r.ok() && *r);
  EXPECT_EQ(f.image.type(), CV_8UC3);  // pixel_format "bgr": straight to BGR
  r = (*src)->read(f);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("not decodable JPEG"), std::string::npos) << r.error();
  EXPECT_NE(r.error().find("truncated"), std::string::npos) << r.error();
  fs::remove_all(dir);
}

// A recording's JPEG file read back as the live source decoded it.
TEST(MjpegDecoder, ReadFrameImageDecodesJpegFilesLikeTheLiveSource) {
  const fs::path dir = fs::temp_directory_path() / "dentar_mjpeg_file";
  fs::create_directories(dir);
  const Bytes j = encode(scene(64, 48, 2), TJSAMP_422);
  const fs::path p = dir / "frame_000000.jpg";
  {
    std::FILE* f = std::fopen(p.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fwrite(j.data(), 1, j.size(), f);
    std::fclose(f);
  }
  MjpegDecoder d;
  cv::Mat live;
  ASSERT_TRUE(d.decode(j.data(), j.size(), MjpegOutput::kYuyv, live));
  auto native = read_frame_image(p.string(), "native");
  ASSERT_TRUE(native.ok()) << native.error();
  EXPECT_EQ(native->type(), CV_8UC2);
  EXPECT_EQ(cv::norm(*native, live, cv::NORM_INF), 0.0);
  auto bgr = read_frame_image(p.string(), "bgr");
  ASSERT_TRUE(bgr.ok()) << bgr.error();
  EXPECT_EQ(bgr->type(), CV_8UC3);
  FrameSourceOptions so;
  so.pixel_format = "native";
  auto folder = FrameSource::open(dir.string(), so);
  ASSERT_TRUE(folder.ok()) << folder.error();
  Frame f;
  ASSERT_TRUE((*folder)->read(f).ok());
  EXPECT_EQ(cv::norm(f.image, live, cv::NORM_INF), 0.0);
  auto missing = read_frame_image((dir / "nope.jpg").string(), "native");
  EXPECT_FALSE(missing.ok());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dentar::ar
