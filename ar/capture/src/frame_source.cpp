#include "dentar/ar/frame_source.h"

#include "dentar/ar/mjpeg_decoder.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <thread>
#include <vector>

namespace dentar::ar {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kMaxConsecutiveFailures = 10;

std::string size_str(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

std::string fps_str(double fps) {
  std::ostringstream os;
  os << fps;
  return os.str();
}

// BGR 8-bit whatever the decoder gave (gray, BGRA).
cv::Mat to_bgr(const cv::Mat& m) {
  if (m.type() == CV_8UC3) return m;
  cv::Mat out;
  if (m.type() == CV_8UC1)
    cv::cvtColor(m, out, cv::COLOR_GRAY2BGR);
  else if (m.type() == CV_8UC4)
    cv::cvtColor(m, out, cv::COLOR_BGRA2BGR);
  else
    m.convertTo(out, CV_8U);  // 16-bit etc.: caller checks the type again
  return out;
}

bool is_jpeg_name(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".jpg" || ext == ".jpeg";
}

// read_frame_image with a decoder the caller keeps (a folder reuses one for all its files).
Result<cv::Mat> read_image(const std::string& path, const std::string& pixel_format, MjpegDecoder& jpeg) {
  if (pixel_format == "native" && is_jpeg_name(path)) {
    std::ifstream in(path, std::ios::binary);
    std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in && !in.eof()) return Error{path + ": cannot be read"};
    cv::Mat m;
    if (!jpeg.decode(bytes.data(), bytes.size(), MjpegOutput::kYuyv, m)) return Error{path + ": " + jpeg.why()};
    return m;
  }
  cv::Mat m = cv::imread(path, cv::IMREAD_COLOR);
  if (m.empty()) return Error{path + ": cannot be decoded as an image"};
  return m;
}

// ---- video file ----
class VideoFileSource final : public FrameSource {
 public:
  static Result<std::unique_ptr<FrameSource>> open(const std::string& path) {
    auto s = std::unique_ptr<VideoFileSource>(new VideoFileSource);
    s->path_ = path;
    s->cap_.open(path, cv::CAP_FFMPEG);
    if (!s->cap_.isOpened())
      return Error{path + ": cannot open as a video (corrupt, or a format FFmpeg does not know); "
                          "check the file with ffprobe, or pass a folder of images"};
    s->fps_ = s->cap_.get(cv::CAP_PROP_FPS);
    if (!std::isfinite(s->fps_) || s->fps_ <= 0 || s->fps_ > 1000) s->fps_ = 30;  // no rate stored
    const double n = s->cap_.get(cv::CAP_PROP_FRAME_COUNT);
    s->count_ = std::isfinite(n) && n > 0 ? static_cast<std::int64_t>(std::llround(n)) : -1;
    // The first frame now: an empty or undecodable file fails at open.
    cv::Mat first;
    if (!s->cap_.read(first) || first.empty())
      return Error{path + ": no decodable frame (empty or corrupt video)"};
    s->first_ = to_bgr(first);
    if (s->first_.type() != CV_8UC3)
      return Error{path + ": frames are not 8-bit images (type " +
                   cv::typeToString(first.type()) + ")"};
    s->width_ = s->first_.cols;
    s->height_ = s->first_.rows;
    s->first_time_ = s->stamp();
    return std::unique_ptr<FrameSource>(std::move(s));
  }

  Result<bool> read(Frame& out) override {
    if (ended_) return false;
    cv::Mat img;
    double t = 0;
    int failed = 0;
    if (!first_.empty()) {
      img = first_;
      first_.release();
      t = first_time_;
    } else {
      for (;;) {
        if (cap_.read(img) && !img.empty()) {
          t = stamp();
          break;
        }
        // End of stream, or a frame that does not decode: FFmpeg says which
        // only through the position; a known frame count tells them apart.
        const bool before_end = count_ > 0 && next_index_ + dropped_ + failed < count_ - 1;
        if (!before_end) {
          ended_ = true;
          if (failed > 0 || (count_ > 0 && next_index_ + dropped_ < count_ - 2))
            return Error{path_ + ": the video ends at frame " + std::to_string(next_index_) +
                         " of " + std::to_string(count_) +
                         " announced (truncated or corrupt file)"};
          return false;
        }
        if (++failed > kMaxConsecutiveFailures)
          return Error{path_ + ": more than " + std::to_string(kMaxConsecutiveFailures) +
                       " frames in a row fail to decode after frame " +
                       std::to_string(next_index_) + " (corrupt file)"};
      }
      img = to_bgr(img);
      if (img.cols != width_ || img.rows != height_ || img.type() != CV_8UC3)
        return Error{path_ + ": frame " + std::to_string(next_index_) + " is " +
                     size_str(img.cols, img.rows) + " but the video started at " +
                     size_str(width_, height_)};
    }
    if (t <= last_time_) t = last_time_ + 1.0 / fps_;  // keep time monotonic
    last_time_ = t;
    dropped_ += failed;
    out.image = img;
    out.index = next_index_++;
    out.time_s = t;
    out.dropped_before = failed;
    out.steady_s = steady_now_s();
    return true;
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  double fps() const override { return fps_; }
  std::int64_t frame_count() const override { return count_; }
  std::int64_t dropped_total() const override { return dropped_; }
  std::string description() const override {
    return "video file " + path_ + " (" + size_str(width_, height_) + ", " + fps_str(fps_) +
           " fps, " + (count_ > 0 ? std::to_string(count_) : std::string("?")) + " frames)";
  }

 private:
  // The container's time of the frame just read, s (index/fps when absent).
  double stamp() {
    const double ms = cap_.get(cv::CAP_PROP_POS_MSEC);
    if (std::isfinite(ms) && ms >= 0 && (ms > 0 || next_index_ == 0)) return ms * 1e-3;
    return static_cast<double>(next_index_ + dropped_) / fps_;
  }
  std::string path_;
  cv::VideoCapture cap_;
  cv::Mat first_;
  double first_time_ = 0, last_time_ = -1, fps_ = 30;
  int width_ = 0, height_ = 0;
  std::int64_t count_ = -1, next_index_ = 0, dropped_ = 0;
  bool ended_ = false;
};

// ---- image folder ----
class FolderSource final : public FrameSource {
 public:
  static Result<std::unique_ptr<FrameSource>> open(const std::string& dir, double fps, const std::string& pixel_format) {
    auto s = std::unique_ptr<FolderSource>(new FolderSource);
    s->dir_ = dir;
    s->fps_ = fps;
    s->pixel_format_ = pixel_format;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      if (!e.is_regular_file()) continue;
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
        return static_cast<char>(std::tolower(c));
      });
      for (const char* k : {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff"})
        if (ext == k) s->files_.push_back(e.path().string());
    }
    if (ec) return Error{dir + ": cannot list the folder: " + ec.message()};
    if (s->files_.empty())
      return Error{dir + ": no image files (png, jpg, bmp, pgm, ppm, tif) in the folder"};
    std::sort(s->files_.begin(), s->files_.end());
    // Size from the first readable image.
    for (const std::string& f : s->files_) {
      cv::Mat m = cv::imread(f, cv::IMREAD_COLOR);
      if (!m.empty()) {
        s->width_ = m.cols;
        s->height_ = m.rows;
        break;
      }
    }
    if (s->width_ == 0)
      return Error{dir + ": none of the " + std::to_string(s->files_.size()) +
                   " image files can be decoded"};
    return std::unique_ptr<FrameSource>(std::move(s));
  }

  Result<bool> read(Frame& out) override {
    int failed = 0;
    for (; pos_ < files_.size(); ++pos_) {
      auto r = read_image(files_[pos_], pixel_format_, jpeg_);
      cv::Mat m = r ? *r : cv::Mat();
      if (m.empty()) {
        if (++failed > kMaxConsecutiveFailures)
          return Error{files_[pos_] + ": more than " + std::to_string(kMaxConsecutiveFailures) +
                       " images in a row cannot be decoded"};
        continue;  // counted below: reported through dropped_before
      }
      if (m.cols != width_ || m.rows != height_)
        return Error{files_[pos_] + ": image is " + size_str(m.cols, m.rows) +
                     " but the sequence started at " + size_str(width_, height_) +
                     "; all frames of a folder must have one size"};
      dropped_ += failed;
      out.image = m;
      out.index = next_index_++;
      out.time_s = static_cast<double>(pos_) / fps_;
      out.dropped_before = failed;
      out.steady_s = steady_now_s();
      ++pos_;
      return true;
    }
    dropped_ += failed;
    if (failed > 0)
      return Error{dir_ + ": the last " + std::to_string(failed) +
                   " image(s) cannot be decoded"};
    return false;
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  double fps() const override { return fps_; }
  std::int64_t frame_count() const override { return static_cast<std::int64_t>(files_.size()); }
  std::int64_t dropped_total() const override { return dropped_; }
  std::string description() const override {
    return "image folder " + dir_ + " (" + std::to_string(files_.size()) + " files, " +
           size_str(width_, height_) + ", " + fps_str(fps_) + " fps)";
  }

 private:
  std::string dir_;
  std::string pixel_format_ = "bgr";  // "native": .jpg files decoded as a live MJPG source does
  MjpegDecoder jpeg_;
  std::vector<std::string> files_;
  std::size_t pos_ = 0;
  double fps_ = 30;
  int width_ = 0, height_ = 0;
  std::int64_t next_index_ = 0, dropped_ = 0;
};

// ---- live camera (or a file standing in for one) ----
class LiveSource final : public FrameSource {
 public:
  LiveSource(std::unique_ptr<cv::VideoCapture> cap, std::string desc, double fps, bool pace,
             FrameSourceOptions options)
      : cap_(std::move(cap)), desc_(std::move(desc)), fps_(fps), pace_(pace), options_(std::move(options)) {}

  Status start() {
    // The format the camera (or the stand-in's file) delivers, against what was
    // asked (frame_source.h). Motion JPEG: keep the camera's own bytes; YUYV with
    // pixel_format "native": keep the camera's own pixels. Both are raw modes of
    // the backend; if the first frame is not what the driver announced, JPEG goes
    // back to the backend's decoding and YUYV is an error naming what came.
    const std::string backend = cap_->getBackendName();
    int delivered = static_cast<int>(cap_->get(cv::CAP_PROP_FOURCC));
    if (backend == "FFMPEG" && delivered != cv::VideoWriter::fourcc('M', 'J', 'P', 'G')) {
      // A stand-in's raw frames: the codec's pixel format says what the bytes are.
      const int pix = static_cast<int>(cap_->get(cv::CAP_PROP_CODEC_PIXEL_FORMAT));
      if (pix == cv::VideoWriter::fourcc('Y', 'U', 'Y', '2')) delivered = pix;
    }
    auto choice = negotiate_format(options_.fourcc, delivered, options_.pixel_format, desc_);
    if (!choice) return Error{choice.error()};
    const auto raw_mode = [&] {
      if (backend == "FFMPEG") return cap_->set(cv::CAP_PROP_FORMAT, -1);
      if (backend == "V4L2") return cap_->set(cv::CAP_PROP_CONVERT_RGB, 0);
      return false;
    };
    if (choice->jpeg) {
      raw_jpeg_ = raw_mode();
      jpeg_out_ = options_.pixel_format == "native" ? MjpegOutput::kYuyv : MjpegOutput::kBgr;
      jpeg_ = MjpegDecoder(options_.jpeg_fast_dct);
    }
    if (choice->yuyv) {
      yuyv_w_ = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_WIDTH));
      yuyv_h_ = static_cast<int>(cap_->get(cv::CAP_PROP_FRAME_HEIGHT));
      if (yuyv_w_ <= 0 || yuyv_h_ <= 0 || yuyv_w_ % 2 != 0)
        return Error{desc_ + ": delivers YUYV frames of " + size_str(yuyv_w_, yuyv_h_) +
                     " (YUYV needs a positive, even width): ask the camera for another mode (--width/--height)"};
      raw_yuyv_ = raw_mode();  // a backend without a raw mode converts to BGR, as before
    }
    t0_ = Clock::now();
    cv::Mat first;
    corrupt_skipped_ = 0;
    if (!grab_retrieve(first) && !bad_format_.empty()) return Error{desc_ + ": " + bad_format_};
    if (first.empty() && raw_jpeg_ && !not_jpeg_.empty()) {
      // The backend accepted raw mode but does not deliver JPEG bytes.
      const bool back = backend == "FFMPEG" ? cap_->set(cv::CAP_PROP_FORMAT, 0)
                                            : cap_->set(cv::CAP_PROP_CONVERT_RGB, 1);
      raw_jpeg_ = false;
      if (!back) return Error{desc_ + ": " + not_jpeg_ + ", and the backend's own decoding cannot be restored"};
      t0_ = Clock::now();
      if (!grab_retrieve(first)) first.release();
    }
    if (first.empty())
      return Error{desc_ + ": opened, but delivers no frame (device busy or unsupported mode? it announces " +
                   fourcc_name(delivered) + "; ask for YUYV or MJPG with --camera-format)"};
    width_ = first.cols;
    height_ = first.rows;
    started_ = true;
    first_ = first;
    first_encoded_ = std::move(encoded_);
    encoded_ = cv::Mat();
    first_corrupt_ = corrupt_skipped_;
    first_time_ = pace_ ? 0.0 : since_open();
    file_pos_ = 1 + first_corrupt_;
    return {};
  }

  Result<bool> read(Frame& out) override {
    cv::Mat img;
    double t = 0;
    int dropped = 0;
    std::int64_t seq = 0;  // the frame's number in the stream, drops counted (Frame::index)
    corrupt_skipped_ = 0;
    if (!first_.empty()) {
      img = first_;
      first_.release();
      encoded_ = std::move(first_encoded_);
      first_encoded_ = cv::Mat();
      t = first_time_;
      dropped = first_corrupt_;  // corrupt JPEGs before the first good one
      seq = dropped;             // ... which were the stream's first frames
      first_corrupt_ = 0;
    } else if (pace_) {
      // The "camera" exposes frame k at k / fps after open. Wait for the
      // next one, or skip those that went by while the consumer was busy.
      const double now = since_open();
      const auto due = static_cast<std::int64_t>(std::floor(now * fps_));
      if (file_pos_ > due) {
        std::this_thread::sleep_for(std::chrono::duration<double>(
            static_cast<double>(file_pos_) / fps_ - now));
      } else {
        while (file_pos_ < due) {
          if (!cap_->grab()) {  // end of the stand-in file: the skipped ones were dropped
            dropped_ += dropped;
            return false;
          }
          ++file_pos_;
          ++dropped;
        }
      }
      const bool got = grab_retrieve(img);
      // Corrupt JPEGs skipped on the way were frames of the stand-in: dropped, and its clock moves on.
      dropped += corrupt_skipped_;
      file_pos_ += corrupt_skipped_;
      if (!got) {
        dropped_ += dropped;
        if (!bad_format_.empty()) return Error{desc_ + ": frame " + std::to_string(index_) + ": " + bad_format_};
        return false;
      }
      t = static_cast<double>(file_pos_) / fps_;
      seq = file_pos_;  // the stand-in's frame in its file
      ++file_pos_;
    } else {
      if (!grab_retrieve(img)) {
        dropped_ += corrupt_skipped_;
        if (!bad_format_.empty()) return Error{desc_ + ": frame " + std::to_string(index_) + ": " + bad_format_};
        return false;  // camera stopped
      }
      t = since_open();
      // A gap of more than 1.5 periods: the driver dropped frames. A corrupt JPEG
      // skipped here is one of them (the larger count of the two, not their sum).
      const double gap = t - last_time_, period = 1.0 / fps_;
      if (last_time_ >= 0 && gap > 1.5 * period)
        dropped = static_cast<int>(std::lround(gap / period)) - 1;
      dropped = std::max(dropped, corrupt_skipped_);
      seq = stream_pos_ + dropped;
    }
    if (!img.empty() && (img.cols != width_ || img.rows != height_))  // empty: JPEG bytes not decoded yet
      return Error{desc_ + ": frame " + std::to_string(index_) + " is " +
                   size_str(img.cols, img.rows) + " but the stream started at " +
                   size_str(width_, height_)};
    if (t <= last_time_) t = last_time_ + 1e-6;
    last_time_ = t;
    dropped_ += dropped;
    out.image = img;
    out.encoded = std::move(encoded_);
    encoded_ = cv::Mat();
    ++index_;
    stream_pos_ = seq + 1;
    out.index = seq;
    out.time_s = t;
    out.dropped_before = dropped;
    out.steady_s = std::chrono::duration<double>(t0_.time_since_epoch()).count() + t;
    return true;
  }
  int width() const override { return width_; }
  int height() const override { return height_; }
  double fps() const override { return fps_; }
  std::int64_t frame_count() const override { return -1; }
  std::int64_t dropped_total() const override { return dropped_; }
  std::string description() const override {
    return desc_ + " (" + size_str(width_, height_) + ", " + fps_str(fps_) + " fps, live" +
           (raw_yuyv_ ? ", YUYV as the camera sent it"
            : raw_jpeg_ ? (jpeg_out_ == MjpegOutput::kYuyv ? ", MJPG decoded to YUYV" : ", MJPG decoded to BGR")
                        : "") +
           (raw_jpeg_ && jpeg_.fast_dct() ? ", fast IDCT" : "") +
           (raw_jpeg_ && options_.defer_jpeg_decode ? ", decoded when taken" : "") + ")";
  }
  std::int64_t corrupt_total() const override { return corrupt_total_; }
  std::string last_corrupt() const override { return last_corrupt_; }

 private:
  double since_open() const { return std::chrono::duration<double>(Clock::now() - t0_).count(); }
  // The next frame (and, in raw JPEG mode, its bytes in encoded_): BGR, or
  // the camera's own YUYV, or a JPEG decoded by MjpegDecoder (YUYV with
  // pixel_format "native", else BGR). false: no frame (end, unplugged), raw
  // bytes that are not JPEG on the first frame (not_jpeg_ says why), or more
  // than kMaxConsecutiveFailures corrupt JPEGs in a row (bad_format_). A JPEG
  // that does not decode (corrupt, truncated on the bus) is skipped and counted
  // (corrupt_skipped_ for this read, corrupt_total_), as a camera's lost frame.
  bool grab_retrieve(cv::Mat& out) {
    cv::Mat m;
    for (int tries = 0;; ++tries) {
      if (!cap_->read(m) || m.empty()) return false;
      if (raw_yuyv_) return take_yuyv(m, out);
      if (!raw_jpeg_) break;
      if (!started_ &&
          (m.rows != 1 || m.type() != CV_8UC1 || m.total() < 4 || m.data[0] != 0xFF || m.data[1] != 0xD8)) {
        not_jpeg_ = "raw frames are not JPEG (" + size_str(m.cols, m.rows) + ", type " + std::to_string(m.type()) + ")";
        return false;
      }
      encoded_ = m.clone();  // the backend reuses its buffer
      if (encoded_.rows != 1) encoded_ = encoded_.reshape(1, 1);
      if (started_ && options_.defer_jpeg_decode) {
        // Handed on undecoded: only the checks that need no pixels (markers, header, size);
        // the consumer decodes the frames it takes (CaptureThread, session 20).
        if (jpeg_.check(encoded_)) {
          out = cv::Mat();
          return true;
        }
      } else if (jpeg_.decode(encoded_, jpeg_out_, out)) {
        if (!started_) jpeg_.expect_size(out.cols, out.rows);  // later frames of another size are damaged
        started_ = true;
        return true;
      }
      last_corrupt_ = jpeg_.why();
      out = cv::Mat();
      encoded_ = cv::Mat();
      ++corrupt_skipped_;
      ++corrupt_total_;
      if (tries >= kMaxConsecutiveFailures) {
        bad_format_ = std::to_string(tries + 1) + " frames in a row are not decodable JPEG (the last: " +
                      last_corrupt_ + "): the camera's stream is damaged (USB bandwidth? cable?)";
        return false;
      }
    }
    out = to_bgr(m);
    return out.type() == CV_8UC3;
  }
  // The camera's own YUYV bytes as one frame (CV_8UC2, W x H, owned: the backend
  // reuses its buffer). The backend hands them as the frame or as one row of
  // bytes; anything of another size is a bad frame (bad_format_ says which).
  bool take_yuyv(const cv::Mat& m, cv::Mat& out) {
    const std::size_t need = static_cast<std::size_t>(yuyv_w_) * static_cast<std::size_t>(yuyv_h_) * 2;
    if (m.type() == CV_8UC2 && m.cols == yuyv_w_ && m.rows == yuyv_h_) {
      out = m.clone();
      return true;
    }
    if (m.type() == CV_8UC1 && m.isContinuous() && m.total() == need) {
      out = m.reshape(2, yuyv_h_).clone();
      return true;
    }
    bad_format_ = "announced YUYV " + size_str(yuyv_w_, yuyv_h_) + " (" + std::to_string(need) +
                  " bytes a frame) but delivered " + std::to_string(m.total() * m.elemSize()) + " bytes (" +
                  size_str(m.cols, m.rows) + ", type " + cv::typeToString(m.type()) +
                  "): the driver does not send what it announces; try --camera-format bgr (the backend's "
                  "conversion) or another mode";
    return false;
  }
  std::unique_ptr<cv::VideoCapture> cap_;
  std::string desc_;
  double fps_ = 30;
  bool pace_ = false;
  FrameSourceOptions options_;
  bool raw_yuyv_ = false;  // handing on the camera's own YUYV (see start())
  int yuyv_w_ = 0, yuyv_h_ = 0;
  std::string bad_format_;  // why the last raw frame was refused
  Clock::time_point t0_;
  cv::Mat first_, first_encoded_, encoded_;
  bool raw_jpeg_ = false;  // reading the camera's JPEG bytes (see start())
  std::string not_jpeg_;
  MjpegDecoder jpeg_;                          // the camera's JPEG frames (mjpeg_decoder.h)
  MjpegOutput jpeg_out_ = MjpegOutput::kBgr;   // kYuyv with pixel_format "native"
  bool started_ = false;                       // the first frame was taken
  int corrupt_skipped_ = 0;                    // corrupt JPEGs skipped by the last grab_retrieve
  int first_corrupt_ = 0;                      // ... before the first frame (start())
  std::int64_t corrupt_total_ = 0;
  std::string last_corrupt_;
  double first_time_ = 0, last_time_ = -1;
  int width_ = 0, height_ = 0;
  std::int64_t index_ = 0, file_pos_ = 0, dropped_ = 0;
  std::int64_t stream_pos_ = 0;  // the next frame's number in the stream (a camera's: drops counted by the gaps)
};

}  // namespace

FrameSource::~FrameSource() = default;

Result<cv::Mat> read_frame_image(const std::string& path, const std::string& pixel_format) {
  MjpegDecoder jpeg;
  return read_image(path, pixel_format, jpeg);
}

double steady_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string FrameSourceOptions::validate() const {
  std::ostringstream os;
  if (width < 0 || width > 16384)
    os << "width = " << width << " px must be in 0..16384 (0 = the camera's default)";
  else if (height < 0 || height > 16384)
    os << "height = " << height << " px must be in 0..16384 (0 = the camera's default)";
  else if (!std::isfinite(fps) || fps < 0 || fps > 1000)
    os << "fps = " << fps << " must be in [0, 1000] (0 = the camera's default)";
  else if (!std::isfinite(folder_fps) || folder_fps <= 0 || folder_fps > 1000)
    os << "folder_fps = " << folder_fps << " must be in (0, 1000]";
  else if (pixel_format != "bgr" && pixel_format != "native")
    os << "pixel_format = \"" << pixel_format << "\" must be \"bgr\" or \"native\" (the camera's own YUYV)";
  else if (!fourcc.empty() && fourcc != "YUYV" && fourcc != "MJPG")
    os << "fourcc = \"" << fourcc << "\" must be empty (the driver's choice), \"YUYV\" or \"MJPG\"";
  return os.str();
}

std::string fourcc_name(int fourcc) {
  if (fourcc == 0) return "none";
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
    if (c < 32 || c > 126) {
      std::ostringstream os;
      os << "0x" << std::hex << static_cast<unsigned>(fourcc);
      return os.str();
    }
    s += c;
  }
  return s;
}

Result<FormatChoice> negotiate_format(const std::string& requested, int delivered, const std::string& pixel_format,
                                      const std::string& what) {
  const int yuyv = cv::VideoWriter::fourcc('Y', 'U', 'Y', 'V'), yuy2 = cv::VideoWriter::fourcc('Y', 'U', 'Y', '2');
  const int mjpg = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  const bool is_yuyv = delivered == yuyv || delivered == yuy2;  // YUY2: the same bytes (Windows' name)
  const bool is_mjpg = delivered == mjpg;
  if (!requested.empty()) {
    const bool ok = (requested == "YUYV" && is_yuyv) || (requested == "MJPG" && is_mjpg);
    if (!ok)
      return Error{what + ": asked for " + requested + " but it delivers " + fourcc_name(delivered) +
                   " (the driver chose another format): list the camera's formats with `v4l2-ctl "
                   "--list-formats-ext` and ask for one it has, or leave the format to the driver"};
  }
  FormatChoice c;
  c.jpeg = is_mjpg;
  c.yuyv = is_yuyv && pixel_format == "native";
  return c;
}

cv::Mat frame_bgr(const cv::Mat& image) {
  if (image.empty() || image.type() == CV_8UC3) return image;
  cv::Mat out;
  if (image.type() == CV_8UC2)
    cv::cvtColor(image, out, cv::COLOR_YUV2BGR_YUYV);
  else
    out = to_bgr(image);
  return out;
}

Status write_yuyv_avi(const std::string& path, const std::vector<cv::Mat>& frames, double fps) {
  if (frames.empty()) return Error{path + ": no frames to write"};
  std::size_t k = 0;
  return write_yuyv_avi(
      path,
      [&](cv::Mat& f) {
        if (k >= frames.size()) return false;
        f = frames[k++];
        return true;
      },
      fps);
}

namespace {

// An AVI 1.0 file of one video stream (`fourcc`, `bitcount` bits a pixel, W x H)
// whose frames are chunks of bytes: next(bytes) fills the next frame's bytes and
// returns true, false after the last, or an error naming the frame. Chunks of odd
// size are padded to an even size (RIFF); idx1 holds each frame's offset and size.
// chunk: "00db" (uncompressed frames) or "00dc" (compressed).
Status write_avi(const std::string& path, int W, int H, const char* fourcc, int bitcount, const char* chunk, double fps,
                 const std::function<Result<bool>(std::vector<std::uint8_t>&, std::uint32_t)>& next) {
  if (!std::isfinite(fps) || fps <= 0 || fps > 1000) return Error{path + ": fps must be in (0, 1000]"};
  std::vector<std::uint8_t> f;
  auto got = next(f, 0);
  if (!got) return Error{got.error()};
  if (!*got) return Error{path + ": no frames to write"};
  const std::uint64_t nominal = static_cast<std::uint64_t>(W) * H * static_cast<std::uint64_t>(bitcount) / 8;
  const std::uint64_t hdrl = 4 + (8 + 56) + 8 + 4 + (8 + 56) + (8 + 40);
  std::ofstream o(path, std::ios::binary);
  if (!o) return Error{path + ": cannot create the file"};
  const auto u32 = [&](std::uint64_t v) {
    const std::uint32_t x = static_cast<std::uint32_t>(v);
    const char b[4] = {char(x & 0xff), char((x >> 8) & 0xff), char((x >> 16) & 0xff), char((x >> 24) & 0xff)};
    o.write(b, 4);
  };
  const auto u16 = [&](int v) {
    const char b[2] = {char(v & 0xff), char((v >> 8) & 0xff)};
    o.write(b, 2);
  };
  const auto tag = [&](const char* t) { o.write(t, 4); };
  // The header with the counts left 0; patched once the frames are known (offsets below).
  tag("RIFF"), u32(0), tag("AVI ");
  tag("LIST"), u32(hdrl), tag("hdrl");
  tag("avih"), u32(56);
  u32(static_cast<std::uint32_t>(std::lround(1e6 / fps))), u32(static_cast<std::uint64_t>(nominal * fps)), u32(0);
  u32(0x10), u32(0) /* 48: frames */, u32(0), u32(1), u32(nominal), u32(W), u32(H), u32(0), u32(0), u32(0), u32(0);
  tag("LIST"), u32(4 + (8 + 56) + (8 + 40)), tag("strl");
  tag("strh"), u32(56), tag("vids"), tag(fourcc), u32(0), u16(0), u16(0), u32(0);
  u32(1000), u32(static_cast<std::uint32_t>(std::lround(fps * 1000))), u32(0), u32(0) /* 140: length */, u32(nominal);
  u32(0xFFFFFFFFu), u32(0), u16(0), u16(0), u16(W), u16(H);
  tag("strf"), u32(40), u32(40), u32(W), u32(H), u16(1), u16(bitcount), tag(fourcc), u32(nominal);
  u32(0), u32(0), u32(0), u32(0);
  tag("LIST"), u32(0) /* 216: movi size */, tag("movi");
  std::vector<std::pair<std::uint64_t, std::uint32_t>> index;  // offset from "movi", size
  std::uint64_t movi = 4;
  std::uint32_t n = 0;
  do {
    const std::uint64_t padded = (f.size() + 1) & ~std::uint64_t{1};
    if (12 + 8 + hdrl + 12 + movi + 8 + padded + 8 + 16 * (n + 1) >= 0xFFFFFFF0ull)
      return Error{path + ": more than 4 GB of frames (one AVI 1.0 file): write fewer frames"};
    index.emplace_back(movi, static_cast<std::uint32_t>(f.size()));
    tag(chunk), u32(f.size());
    o.write(reinterpret_cast<const char*>(f.data()), static_cast<std::streamsize>(f.size()));
    if (padded != f.size()) o.put('\0');
    movi += 8 + padded;
    ++n;
    got = next(f, n);
    if (!got) return Error{got.error()};
  } while (*got);
  tag("idx1"), u32(16 * n);
  for (const auto& [off, size] : index) tag(chunk), u32(0x10), u32(off), u32(size);
  const std::uint64_t riff = 4 + (8 + hdrl) + (8 + movi) + 8 + 16 * n;
  o.seekp(4), u32(riff);
  o.seekp(48), u32(n);
  o.seekp(140), u32(n);
  o.seekp(216), u32(movi);
  o.close();
  if (!o) return Error{path + ": write failed (disk full?)"};
  return {};
}

}  // namespace

Status write_yuyv_avi(const std::string& path, const std::function<bool(cv::Mat&)>& next, double fps) {
  cv::Mat f;
  if (!next(f) || f.empty()) return Error{path + ": no frames to write"};
  const int W = f.cols, H = f.rows;
  bool first = true;
  return write_avi(path, W, H, "YUY2", 16, "00db", fps, [&](std::vector<std::uint8_t>& bytes, std::uint32_t n) -> Result<bool> {
    if (!first && (!next(f) || f.empty())) return false;
    first = false;
    if (f.type() != CV_8UC2 || f.cols != W || f.rows != H || W % 2 != 0)
      return Error{path + ": frame " + std::to_string(n) + " is not YUYV (CV_8UC2) of " + size_str(W, H) +
                   " with an even width"};
    bytes.resize(static_cast<std::size_t>(W) * H * 2);
    for (int y = 0; y < H; ++y)
      std::memcpy(bytes.data() + static_cast<std::size_t>(y) * W * 2, f.ptr(y), static_cast<std::size_t>(W) * 2);
    return true;
  });
}

Status write_mjpeg_avi(const std::string& path, const std::vector<std::vector<std::uint8_t>>& jpegs, int width,
                       int height, double fps) {
  if (jpegs.empty()) return Error{path + ": no frames to write"};
  if (width <= 0 || height <= 0 || width > 65535 || height > 65535)
    return Error{path + ": frame size " + size_str(width, height) + " must be positive and below 65536"};
  return write_avi(path, width, height, "MJPG", 24, "00dc", fps, [&](std::vector<std::uint8_t>& bytes, std::uint32_t n) -> Result<bool> {
    if (n >= jpegs.size()) return false;
    bytes = jpegs[n];
    return true;
  });
}

Status write_mjpeg_avi(const std::string& path, const std::function<bool(std::vector<std::uint8_t>&)>& next, int width,
                       int height, double fps) {
  if (width <= 0 || height <= 0 || width > 65535 || height > 65535)
    return Error{path + ": frame size " + size_str(width, height) + " must be positive and below 65536"};
  return write_avi(path, width, height, "MJPG", 24, "00dc", fps,
                   [&](std::vector<std::uint8_t>& bytes, std::uint32_t) -> Result<bool> { return next(bytes); });
}

Result<std::unique_ptr<FrameSource>> FrameSource::open_live(
    std::unique_ptr<cv::VideoCapture> capture, const std::string& description, double fps,
    bool pace, const FrameSourceOptions& options) {
  if (!capture || !capture->isOpened()) return Error{description + ": capture is not open"};
  if (auto e = options.validate(); !e.empty()) return Error{"FrameSourceOptions: " + e};
  if (!std::isfinite(fps) || fps <= 0 || fps > 1000) fps = 30;  // driver did not say
  auto s = std::make_unique<LiveSource>(std::move(capture), description, fps, pace, options);
  if (Status st = s->start(); !st) return Error{st.error()};
  return std::unique_ptr<FrameSource>(std::move(s));
}

Result<std::unique_ptr<FrameSource>> FrameSource::open(const std::string& spec,
                                                       const FrameSourceOptions& options) {
  if (auto e = options.validate(); !e.empty()) return Error{"FrameSourceOptions: " + e};
  if (spec.empty()) return Error{"frame source: empty input (give a video, a folder or camera:N)"};

  // Live camera: camera:N or /dev/videoN.
  const bool is_index = spec.rfind("camera:", 0) == 0;
  const bool is_dev = spec.rfind("/dev/video", 0) == 0;
  if (is_index || is_dev) {
    auto cap = std::make_unique<cv::VideoCapture>();
    if (is_index) {
      const std::string n = spec.substr(7);
      if (n.empty() || n.size() > 3 || !std::all_of(n.begin(), n.end(), ::isdigit))
        return Error{spec + ": camera index must be a number (camera:0, camera:1, ...)"};
      if (!fs::exists("/dev/video" + n))
        return Error{spec + ": no camera /dev/video" + n +
                     " on this machine (list them with v4l2-ctl --list-devices)"};
      cap->open(std::stoi(n), cv::CAP_V4L2);
    } else {
      if (!fs::exists(spec))
        return Error{spec + ": no such camera device (list them with v4l2-ctl --list-devices)"};
      cap->open(spec, cv::CAP_V4L2);
    }
    if (!cap->isOpened())
      return Error{spec + ": cannot open the camera through V4L2 (busy, no permission, or not "
                          "a capture device)"};
    if (options.fourcc.size() == 4)  // before the size: the modes a format has differ
      cap->set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(options.fourcc[0], options.fourcc[1],
                                                            options.fourcc[2], options.fourcc[3]));
    if (options.width > 0) cap->set(cv::CAP_PROP_FRAME_WIDTH, options.width);
    if (options.height > 0) cap->set(cv::CAP_PROP_FRAME_HEIGHT, options.height);
    if (options.fps > 0) cap->set(cv::CAP_PROP_FPS, options.fps);
    const double fps = cap->get(cv::CAP_PROP_FPS);
    return open_live(std::move(cap), "camera " + spec, fps > 0 ? fps : options.fps, false, options);
  }

  // A file standing in for a live camera.
  if (spec.rfind("live:", 0) == 0) {
    const std::string path = spec.substr(5);
    if (!fs::is_regular_file(path)) return Error{path + ": no such video file (live:PATH)"};
    auto cap = std::make_unique<cv::VideoCapture>(path, cv::CAP_FFMPEG);
    if (!cap->isOpened())
      return Error{path + ": cannot open as a video (corrupt, or a format FFmpeg does not know)"};
    const double fps = cap->get(cv::CAP_PROP_FPS);
    return open_live(std::move(cap), "live stand-in " + path, fps, true, options);
  }

  std::error_code ec;
  if (!fs::exists(spec, ec))
    return Error{spec + ": no such file or folder (give a video file, an image folder, "
                        "camera:N or /dev/videoN)"};
  if (fs::is_directory(spec, ec)) return FolderSource::open(spec, options.folder_fps, options.pixel_format);
  if (!fs::is_regular_file(spec, ec)) return Error{spec + ": not a regular file or folder"};
  if (fs::file_size(spec, ec) == 0) return Error{spec + ": empty file (0 bytes), not a video"};
  return VideoFileSource::open(spec);
}

}  // namespace dentar::ar
