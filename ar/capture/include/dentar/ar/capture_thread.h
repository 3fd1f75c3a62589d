// CaptureThread: reads a FrameSource on its own thread and keeps only the
// newest frame ("latest frame wins"): a slow consumer never sees a queue of
// stale frames. Frames replaced before anyone took them are counted as
// dropped, beside the drops the source itself reports.
//
// When the source fails or ends (a camera unplugged, a stand-in file at its
// end), the thread says so in status() and, if `reopen` is set, reopens the
// same spec every reopen_period_s until it delivers again. A stall (no frame
// for a while) is visible to the consumer through last_frame_steady_s().
// Capture times (Frame::time_s) stay monotonic across a reopen.
//
// Threads: one capture thread inside; take()/wait_take()/status() from any
// one consumer thread.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "dentar/ar/frame_source.h"

namespace dentar::ar {

struct CaptureThreadOptions {
  bool reopen = true;            // reopen a failed/ended source
  double reopen_period_s = 0.5;  // between reopen attempts
  // Test hook: after this many frames, deliver nothing for stall_s seconds
  // (the source keeps being read and its frames thrown away, as when a
  // camera's cable is pulled). 0 = never.
  std::int64_t stall_after_frames = 0;
  double stall_s = 0;
  // Called once on the capture thread before it reads (CPU affinity); may be empty.
  std::function<void()> thread_init;
};

class CaptureThread {
 public:
  // Takes an opened source; `spec` and `options` are used to reopen it.
  CaptureThread(std::unique_ptr<FrameSource> source, std::string spec, FrameSourceOptions source_options,
                CaptureThreadOptions options = {});
  ~CaptureThread();  // stops and joins
  CaptureThread(const CaptureThread&) = delete;
  CaptureThread& operator=(const CaptureThread&) = delete;

  void start();
  void stop();
  // The newest frame not taken yet; false when there is none. Waits up to
  // timeout_s for one.
  bool wait_take(Frame& out, double timeout_s);
  // steady_clock time (s) of the newest frame delivered, 0 before the first.
  double last_frame_steady_s() const { return last_steady_s_.load(std::memory_order_acquire); }
  std::int64_t delivered() const { return delivered_.load(); }
  std::int64_t dropped_consumer() const { return dropped_consumer_.load(); }  // replaced before taken
  std::int64_t dropped_source() const { return dropped_source_.load(); }      // reported by the source
  std::int64_t reopens() const { return reopens_.load(); }
  // Motion JPEG frames the source refused as corrupt or truncated (part of
  // dropped_source), over every reopen, and the last one's reason ("" none).
  std::int64_t corrupt() const { return corrupt_.load(); }
  std::string last_corrupt() const;
  bool ended() const { return ended_.load(); }  // the source ended and will not be reopened
  std::string status() const;                   // "" when all is well, else why not
  int width() const { return width_; }
  int height() const { return height_; }
  double fps() const { return fps_; }
  std::string description() const { return description_; }

 private:
  void main();
  void set_status(const std::string& s);

  std::unique_ptr<FrameSource> source_;
  std::string spec_;
  FrameSourceOptions source_options_;
  CaptureThreadOptions options_;
  int width_ = 0, height_ = 0;
  double fps_ = 0;
  std::string description_;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  Frame slot_;
  bool slot_full_ = false;
  std::string status_;

  double time_offset_ = 0, last_time_s_ = 0;  // capture thread: Frame::time_s across reopens
  std::atomic<double> last_steady_s_{0};
  std::atomic<std::int64_t> delivered_{0}, dropped_consumer_{0}, dropped_source_{0}, reopens_{0};
  std::atomic<std::int64_t> corrupt_{0};
  std::int64_t corrupt_before_ = 0;  // corrupt frames of the sources before a reopen (capture thread)
  std::string last_corrupt_;         // under mutex_
  std::atomic<bool> stop_{false}, ended_{false};
  std::thread thread_;
};

}  // namespace dentar::ar
