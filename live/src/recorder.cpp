// The live recording's writer thread. See recorder.h.
#include "recorder.h"

#include <cstdio>
#include <ctime>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <vector>

namespace dentar::live {
namespace fs = std::filesystem;

namespace {

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}

const char* state_name(int s) {
  static const char* kNames[] = {"tracking", "predicted", "lost"};
  return s >= 0 && s <= 2 ? kNames[s] : "lost";
}

// 12 numbers, row-major 3x4, or empty when lost.
std::string pose(int state, const Eigen::Isometry3d& T) {
  if (state == 2) return {};
  std::ostringstream s;
  s << std::setprecision(17);
  const Eigen::Matrix4d m = T.matrix();
  for (int i = 0; i < 12; ++i) s << (i ? " " : "") << m(i / 4, i % 4);
  return s.str();
}

}  // namespace

Result<std::unique_ptr<Recorder>> Recorder::open(const fs::path& dir) {
  std::unique_ptr<Recorder> r(new Recorder);
  r->dir_ = dir;
  std::error_code ec;
  fs::create_directories(dir / "frames", ec);
  if (ec) return Error{dir.string() + ": cannot create the recording folder: " + ec.message()};
  r->csv_.open(dir / "frames.csv");
  if (!r->csv_) return Error{(dir / "frames.csv").string() + ": cannot write"};
  r->csv_ << "frame,time_s,steady_s,source_index,haptic_steps,man_state,mirror_state,pen_state,"
             "man_T,mirror_T,pedal,force_N,overlay,track_ms,mesh_ms,composite_ms,disc_start,disc_merged,pose_step\n";
  r->csv_.flush();
  r->log_.open(dir / "live.log");
  r->thread_ = std::thread([p = r.get()] { p->main(); });
  return r;
}

Recorder::~Recorder() { close(); }

void Recorder::push(const cv::Mat& raw, const cv::Mat& encoded, const ar::FrameRecord& rec, std::int64_t index,
                    std::int64_t source_index, double steady_s) {
  std::lock_guard<std::mutex> lock(m_);
  if (q_.size() > kMaxQueued) {
    ++dropped_;
    return;
  }
  q_.push_back(Item{raw, encoded, rec, index, source_index, steady_s});
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

bool Recorder::write_frame(const Item& it, std::size_t behind) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "frame_%06lld", static_cast<long long>(it.index));
  const std::string ext = !it.encoded.empty() ? ".jpg" : behind >= kFastFromQueued ? ".ppm" : ".png";
  const fs::path final_path = dir_ / "frames" / (stem + ext);
  // Written as .part (not an image name: a crash mid-write leaves nothing
  // that a replay would read as a frame), then renamed.
  const fs::path part = dir_ / "frames" / (stem + ext + ".part");
  std::vector<uchar> buf;
  const uchar* data = it.encoded.data;
  std::size_t n = it.encoded.total() * it.encoded.elemSize();
  if (it.encoded.empty()) {
    const bool ok = ext == ".ppm" ? cv::imencode(ext, it.raw, buf, {cv::IMWRITE_PXM_BINARY, 1})
                                  : cv::imencode(ext, it.raw, buf, {cv::IMWRITE_PNG_COMPRESSION, 1});
    if (!ok) return false;
    data = buf.data();
    n = buf.size();
  }
  std::FILE* f = std::fopen(part.c_str(), "wb");
  if (!f) return false;
  const bool wrote = std::fwrite(data, 1, n, f) == n;
  if (std::fclose(f) != 0 || !wrote) return false;
  std::error_code ec;
  fs::rename(part, final_path, ec);
  if (ec) return false;
  (ext == ".jpg" ? n_jpg_ : ext == ".ppm" ? n_ppm_ : n_png_)++;
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
    const ar::FrameRecord& r = it.rec;
    csv_ << std::setprecision(17) << it.index << ',' << r.time_s << ',' << it.steady_s << ',' << it.source_index
         << ',' << r.haptic_steps_done << ',' << state_name(r.man_state) << ',' << state_name(r.mir_state) << ','
         << state_name(r.pen_state) << ',' << pose(r.man_state, r.T_cam_man) << ','
         << pose(r.mir_state, r.T_cam_mtag) << ',' << (r.pedal ? 1 : 0) << ',' << std::setprecision(6) << r.force_N
         << ',' << (r.overlay ? 1 : 0) << ',' << r.track_ms << ',' << r.mesh_ms << ',' << r.composite_ms << ','
         << (r.disc_start ? 1 : 0) << ',' << r.disc_merged << ',' << std::setprecision(17) << r.pose_step << '\n';
    csv_.flush();
    ++written_;
  }
}

}  // namespace dentar::live
