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
// Decode on demand (issue 28, session 20; FrameSourceOptions::defer_jpeg_decode):
// a Motion JPEG source hands on its packets undecoded, and the slot holds the
// newest packet. A packet replaced before anyone took it is dropped without being
// decoded (skipped_undecoded). A packet is decoded only for a consumer: on the
// capture thread when the consumer is already waiting in wait_take as it arrives
// (the decode stays off the consumer's thread, as before), else on the consumer's
// thread inside wait_take, when it takes the packet. So decodes() <= frames taken
// + 1 (a consumer that stops waiting while its frame is being decoded), whatever
// the rates. The capture time (Frame::time_s, steady_s) is the packet's, never the
// decode's. A packet that does not decode is dropped and counted (corrupt(),
// dropped_source()) and wait_take goes on to the next one; 11 in a row set status().
// Other sources (YUYV, BGR, files) and a source without deferral: as before.
//
// Eager newest-packet decode (issue 28, session 21; CaptureThreadOptions::eager_decode, with a
// deferring source): the capture side keeps the newest undecoded packet and decodes it as soon
// as nothing decoded is waiting (at once when the slot is empty, else the moment the consumer
// takes the decoded frame), on a decode thread of the capture (thread_init runs on it too, so it
// carries the capture thread's name and CPUs: the summary counts its CPU as the capture's). The
// capture thread itself cannot do it: it blocks in the camera's read, which a take cannot wake.
// A packet superseded before its decode started is never decoded (skipped_undecoded); a decode
// once started finishes and its frame is delivered. The consumer never decodes: wait_take takes
// the decoded frame at once when one is ready, else waits for the one being decoded. So
// decodes() <= frames taken + 1 (+ the first frame, which the source decodes to learn the size).
// A decoded frame waiting is never replaced: a consumer slower than the camera takes the frame
// decoded after its previous take (up to one of its own periods old), not the newest packet.
//
// Threads: one capture thread inside; wait_take()/status() from any one consumer
// thread (the decode on take uses a decoder of its own).
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
#include "dentar/ar/mjpeg_decoder.h"

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
  // With a source that defers its Motion JPEG decode (FrameSourceOptions::defer_jpeg_decode):
  // decode the newest packet eagerly on the capture side (see above) instead of on demand.
  bool eager_decode = false;
  // A gap between two delivered frames longer than this is a silence (last_silence()), s.
  double silence_s = 0.1;
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
  // The same, but only a frame captured at or after min_steady_s (steady clock, s):
  // an older one in the slot is dropped (counted in dropped_consumer, and in
  // skipped_undecoded when it was not decoded) and the wait goes on. A stereo
  // pairing takes the partner it can use without decoding the ones it cannot.
  // passed_s (optional): the newest passed-over frame's capture time, 0 if none.
  bool wait_take_since(Frame& out, double timeout_s, double min_steady_s, double* passed_s = nullptr);
  // The capture time of the frame a take would return now without waiting (decoded, or an
  // undecoded packet on demand); 0 when none. The freshest-pair rule's peek: the same frames
  // as a take with timeout 0 (a packet still being decoded eagerly is not waiting yet).
  double ready_steady_s() const;
  // Waits up to timeout_s until the frame a take would return now was captured at or after
  // min_steady_s (steady clock, s), without taking it; false: none by then (or stopping).
  bool wait_ready(double timeout_s, double min_steady_s);
  // steady_clock time (s) of the newest frame delivered, 0 before the first. Every frame the
  // camera delivered counts, taken or not (passed over, replaced, never decoded): the camera's
  // last-seen time, whatever the consumer takes.
  double last_frame_steady_s() const { return last_steady_s_.load(std::memory_order_acquire); }
  // Session 22: the capture time (steady s) of the newest frame delivered after a silence of
  // more than CaptureThreadOptions::silence_s (no frame delivered), and the last frame before
  // that silence; 0, 0 before any. Seen on the capture thread, frame by frame: a consumer that
  // takes few frames (a stereo pairing passing over, eager decode skipping packets) sees no
  // silence that was not there, and misses none that was.
  struct Silence {
    double last_before_s = 0, first_after_s = 0;
  };
  Silence last_silence() const;
  std::int64_t delivered() const { return delivered_.load(); }
  std::int64_t dropped_consumer() const { return dropped_consumer_.load(); }  // replaced before taken
  std::int64_t dropped_source() const { return dropped_source_.load(); }      // reported by the source
  std::int64_t reopens() const { return reopens_.load(); }
  // Motion JPEG frames the source refused as corrupt or truncated (part of
  // dropped_source), over every reopen, and the last one's reason ("" none).
  std::int64_t corrupt() const { return corrupt_.load() + decode_corrupt_.load(); }
  std::string last_corrupt() const;
  // Motion JPEG decodes made for this thread's frames (tries, the failed ones too),
  // either way: every delivered frame without decode on demand, else only the
  // frames taken (see above). Packets replaced or passed over before anyone took
  // them, never decoded (decode on demand only).
  std::int64_t decodes() const { return decodes_.load(); }
  std::int64_t skipped_undecoded() const { return skipped_undecoded_.load(); }
  bool decode_on_demand() const { return source_options_.defer_jpeg_decode && !options_.eager_decode; }
  bool decode_eager() const { return source_options_.defer_jpeg_decode && options_.eager_decode; }
  bool ended() const { return ended_.load(); }  // the source ended and will not be reopened
  std::string status() const;                   // "" when all is well, else why not
  int width() const { return width_; }
  int height() const { return height_; }
  double fps() const { return fps_; }
  std::string description() const { return description_; }

 private:
  void main();
  void decode_main();  // eager decode: the newest packet, when nothing decoded waits
  void set_status(const std::string& s);
  // Decodes an undecoded frame in place with `dec`; false: refused (counted). No lock held.
  bool decode(MjpegDecoder& dec, Frame& f);
  void count_decode(bool ok, const MjpegDecoder& dec);  // under mutex_

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
  Silence silence_;  // under mutex_
  std::atomic<std::int64_t> delivered_{0}, dropped_consumer_{0}, dropped_source_{0}, reopens_{0};
  std::atomic<std::int64_t> corrupt_{0};  // refused by the sources (their corrupt_total)
  std::int64_t corrupt_before_ = 0;  // corrupt frames of the sources before a reopen (capture thread)
  std::string last_corrupt_;         // under mutex_
  // Decode on demand: the consumer is inside wait_take (under mutex_); one decoder
  // per thread (capture thread, consumer); consecutive failed decodes (under mutex_).
  bool consumer_waiting_ = false;
  MjpegDecoder capture_decoder_, take_decoder_;
  MjpegOutput jpeg_out_ = MjpegOutput::kBgr;
  int bad_in_row_ = 0;
  static constexpr int kMaxBadInRow = 10;  // more in a row: status() says the stream is damaged
  std::atomic<std::int64_t> decodes_{0}, skipped_undecoded_{0}, decode_corrupt_{0};
  // Eager decode (under mutex_): the newest undecoded packet; the capture time of the one being
  // decoded (0: none); decode_cv_ wakes the decode thread (a packet came, the slot was emptied).
  Frame pending_;
  bool pending_full_ = false;
  double decoding_steady_s_ = 0;
  std::condition_variable decode_cv_;
  std::atomic<bool> stop_{false}, ended_{false};
  std::thread thread_, decode_thread_;
};

}  // namespace dentar::ar
