// The live recording's writer thread. See recorder.h.
#include "dentar/session/recorder.h"

#include "dentar/session/frames_csv.h"

#include <cstdio>
#include <ctime>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

namespace dentar::session {
namespace fs = std::filesystem;

namespace {

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

}  // namespace

Result<std::unique_ptr<Recorder>> Recorder::open(const fs::path& dir, bool stereo) {
  std::unique_ptr<Recorder> r(new Recorder);
  r->dir_ = dir;
  r->stereo_ = stereo;
  std::error_code ec;
  fs::create_directories(dir / "frames", ec);
  if (!ec && stereo) fs::create_directories(dir / "frames_right", ec);
  if (ec) return Error{dir.string() + ": cannot create the recording folder: " + ec.message()};
  r->csv_.open(dir / "frames.csv");
  if (!r->csv_) return Error{(dir / "frames.csv").string() + ": cannot write"};
  r->csv_ << recording_csv_header(stereo);
  r->csv_.flush();
  r->log_.open(dir / "live.log");
  r->thread_ = std::thread([p = r.get()] { p->main(); });
  return r;
}

Recorder::~Recorder() { close(); }

void Recorder::push(const cv::Mat& raw, const cv::Mat& encoded, const ar::FrameRecord& rec, std::int64_t index,
                    std::int64_t source_index, double steady_s, const cv::Mat& right_raw,
                    const cv::Mat& right_encoded) {
  std::lock_guard<std::mutex> lock(m_);
  if (q_.size() > kMaxQueued) {
    ++dropped_;
    return;
  }
  q_.push_back(Item{raw, encoded, stereo_ ? right_raw : cv::Mat(), stereo_ ? right_encoded : cv::Mat(), rec, index,
                    source_index, steady_s});
  cv_.notify_one();
}

void Recorder::log(const std::string& line) {
  std::lock_guard<std::mutex> lock(m_);
  log_ << utc_now() << " " << line << "\n";
  log_.flush();
}

void Recorder::close() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::string Recorder::write_image(const fs::path& frames_dir, std::int64_t index, const cv::Mat& raw,
                                  const cv::Mat& encoded, std::size_t behind) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "frame_%06lld", static_cast<long long>(index));
  const std::string ext = !encoded.empty() ? ".jpg" : behind >= kFastFromQueued ? ".ppm" : ".png";
  const fs::path final_path = frames_dir / (stem + ext);
  // Written as .part (not an image name: a crash mid-write leaves nothing
  // that a replay would read as a frame), then renamed.
  const fs::path part = frames_dir / (stem + ext + ".part");
  std::vector<uchar> buf;
  const uchar* data = encoded.data;
  std::size_t n = encoded.total() * encoded.elemSize();
  if (encoded.empty()) {
    // The camera's own YUYV (issue 28) becomes BGR here, on the writer thread, not the frame thread's.
    cv::Mat img = raw;
    if (raw.type() == CV_8UC2) cv::cvtColor(raw, img, cv::COLOR_YUV2BGR_YUYV);
    const bool ok = ext == ".ppm" ? cv::imencode(ext, img, buf, {cv::IMWRITE_PXM_BINARY, 1})
                                  : cv::imencode(ext, img, buf, {cv::IMWRITE_PNG_COMPRESSION, 1});
    if (!ok) return {};
    data = buf.data();
    n = buf.size();
  }
  std::FILE* f = std::fopen(part.c_str(), "wb");
  if (!f) return {};
  const bool wrote = std::fwrite(data, 1, n, f) == n;
  if (std::fclose(f) != 0 || !wrote) return {};
  std::error_code ec;
  fs::rename(part, final_path, ec);
  if (ec) return {};
  return ext;
}

bool Recorder::write_frame(const Item& it, std::size_t behind) {
  // The right eye first: once the left eye's file is there, the frame is whole.
  std::string right_ext;
  if (!it.right_raw.empty()) {
    right_ext = write_image(dir_ / "frames_right", it.index, it.right_raw, it.right_encoded, behind);
    if (right_ext.empty()) return false;
  }
  const std::string ext = write_image(dir_ / "frames", it.index, it.raw, it.encoded, behind);
  if (ext.empty()) return false;
  (ext == ".jpg" ? n_jpg_ : ext == ".ppm" ? n_ppm_ : n_png_)++;
  if (!right_ext.empty()) (right_ext == ".jpg" ? n_right_jpg_ : right_ext == ".ppm" ? n_right_ppm_ : n_right_png_)++;
  return true;
}

void Recorder::main() {
  for (;;) {
    Item it;
    std::size_t behind = 0;
    {
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [&] { return stop_ || !q_.empty(); });
      if (q_.empty()) return;
      it = std::move(q_.front());
      q_.pop_front();
      behind = q_.size();
    }
    if (!write_frame(it, behind)) {
      ++dropped_;
      continue;
    }
    csv_ << recording_csv_row(it.rec, it.index, it.steady_s, it.source_index, stereo_);
    csv_.flush();
    ++written_;
  }
}

}  // namespace dentar::session
