#include "dentar/ar/capture_thread.h"

#include <chrono>

namespace dentar::ar {

CaptureThread::CaptureThread(std::unique_ptr<FrameSource> source, std::string spec,
                             FrameSourceOptions source_options, CaptureThreadOptions options)
    : source_(std::move(source)), spec_(std::move(spec)), source_options_(source_options), options_(options) {
  width_ = source_->width();
  height_ = source_->height();
  fps_ = source_->fps();
  description_ = source_->description();
}

CaptureThread::~CaptureThread() { stop(); }

void CaptureThread::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] {
    if (options_.thread_init) options_.thread_init();
    main();
  });
}

void CaptureThread::stop() {
  stop_.store(true);
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void CaptureThread::set_status(const std::string& s) {
  std::lock_guard<std::mutex> lock(mutex_);
  status_ = s;
}

std::string CaptureThread::last_corrupt() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_corrupt_;
}

std::string CaptureThread::status() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return status_;
}

bool CaptureThread::wait_take(Frame& out, double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] { return slot_full_ || stop_.load(); });
  if (!slot_full_) return false;
  out = std::move(slot_);
  slot_ = Frame{};
  slot_full_ = false;
  return true;
}

void CaptureThread::main() {
  std::int64_t count = 0;
  double stall_until = -1;
  while (!stop_.load()) {
    if (!source_) {
      // Reopen the same spec until it delivers again.
      auto src = FrameSource::open(spec_, source_options_);
      if (src && (*src)->width() == width_ && (*src)->height() == height_) {
        source_ = std::move(*src);
        reopens_.fetch_add(1);
        // A reopened source counts its time from 0 again: keep capture times
        // monotonic across the reopen (one frame period after the last).
        time_offset_ = last_time_s_ + (fps_ > 0 ? 1.0 / fps_ : 1.0 / 30);
        set_status("");
      } else {
        set_status(src ? spec_ + ": came back at another size; not used"
                       : "camera lost: " + src.error() + " (retrying)");
        std::this_thread::sleep_for(std::chrono::duration<double>(options_.reopen_period_s));
        continue;
      }
    }
    Frame f;
    auto got = source_->read(f);
    if (const std::int64_t c = corrupt_before_ + source_->corrupt_total(); c != corrupt_.load()) {
      corrupt_.store(c);
      std::lock_guard<std::mutex> lock(mutex_);
      last_corrupt_ = source_->last_corrupt();
    }
    if (!got || !*got) {
      set_status(got ? source_->description() + ": stopped delivering (end of stream or unplugged)"
                     : got.error());
      corrupt_before_ += source_->corrupt_total();
      source_.reset();
      if (!options_.reopen) {
        ended_.store(true);
        cv_.notify_all();
        return;
      }
      continue;
    }
    ++count;
    f.time_s += time_offset_;
    last_time_s_ = f.time_s;
    dropped_source_.fetch_add(f.dropped_before);
    if (options_.stall_after_frames > 0 && count == options_.stall_after_frames)
      stall_until = f.steady_s + options_.stall_s;
    if (stall_until > 0 && f.steady_s < stall_until) continue;  // the stall test hook
    last_steady_s_.store(f.steady_s, std::memory_order_release);
    delivered_.fetch_add(1);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (slot_full_) dropped_consumer_.fetch_add(1);
      slot_ = std::move(f);
      slot_full_ = true;
    }
    cv_.notify_one();
  }
}

}  // namespace dentar::ar
