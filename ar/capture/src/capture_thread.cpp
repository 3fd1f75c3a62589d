#include "dentar/ar/capture_thread.h"

#include <algorithm>
#include <chrono>
#include <limits>

namespace dentar::ar {

CaptureThread::CaptureThread(std::unique_ptr<FrameSource> source, std::string spec,
                             FrameSourceOptions source_options, CaptureThreadOptions options)
    : source_(std::move(source)), spec_(std::move(spec)), source_options_(source_options), options_(options) {
  width_ = source_->width();
  height_ = source_->height();
  fps_ = source_->fps();
  description_ = source_->description();
  jpeg_out_ = source_options_.pixel_format == "native" ? MjpegOutput::kYuyv : MjpegOutput::kBgr;
  capture_decoder_ = MjpegDecoder(source_options_.jpeg_fast_dct);
  take_decoder_ = MjpegDecoder(source_options_.jpeg_fast_dct);
  capture_decoder_.expect_size(width_, height_);  // later frames of another size are damaged
  take_decoder_.expect_size(width_, height_);
}

CaptureThread::~CaptureThread() { stop(); }

void CaptureThread::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] {
    if (options_.thread_init) options_.thread_init();
    main();
  });
  if (decode_eager())
    decode_thread_ = std::thread([this] {
      if (options_.thread_init) options_.thread_init();  // the capture's name and CPUs
      decode_main();
    });
}

void CaptureThread::stop() {
  stop_.store(true);
  { std::lock_guard<std::mutex> lock(mutex_); }  // a waiter has checked stop_ or is waiting: no lost wake
  cv_.notify_all();
  decode_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (decode_thread_.joinable()) decode_thread_.join();
}

CaptureThread::Silence CaptureThread::last_silence() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return silence_;
}

double CaptureThread::ready_steady_s() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return slot_full_ ? slot_.steady_s : 0;
}

bool CaptureThread::wait_ready(double timeout_s, double min_steady_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(std::max(0.0, timeout_s)));
  consumer_waiting_ = true;  // on demand: a packet arriving now is decoded on the capture thread
  const bool ok = cv_.wait_until(lock, deadline, [&] {
    return stop_.load() || (slot_full_ && slot_.steady_s >= min_steady_s);
  });
  consumer_waiting_ = false;
  return ok && !stop_.load();
}

void CaptureThread::decode_main() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    decode_cv_.wait(lock, [&] { return stop_.load() || (pending_full_ && !slot_full_); });
    if (stop_.load()) return;
    Frame f = std::move(pending_);  // the newest packet: nothing superseded it before this start
    pending_ = Frame{};
    pending_full_ = false;
    decoding_steady_s_ = f.steady_s;
    lock.unlock();
    const bool ok = decode(capture_decoder_, f);
    lock.lock();
    decoding_steady_s_ = 0;
    count_decode(ok, capture_decoder_);
    if (!ok) continue;  // dropped and counted; the consumer waits for the next
    if (slot_full_) {   // only a frame the source decoded itself (a reopened source's first)
      dropped_consumer_.fetch_add(1);
      if (slot_.steady_s >= f.steady_s) continue;  // the newer one stays
    }
    slot_ = std::move(f);
    slot_full_ = true;
    cv_.notify_one();
  }
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
  return wait_take_since(out, timeout_s, -std::numeric_limits<double>::infinity());
}

bool CaptureThread::decode(MjpegDecoder& dec, Frame& f) {
  cv::Mat img;
  if (!dec.decode(f.encoded, jpeg_out_, img)) return false;
  f.image = std::move(img);
  return true;
}

void CaptureThread::count_decode(bool ok, const MjpegDecoder& dec) {
  decodes_.fetch_add(1);
  if (ok) {
    if (bad_in_row_ > kMaxBadInRow) status_.clear();  // the stream decodes again
    bad_in_row_ = 0;
    return;
  }
  decode_corrupt_.fetch_add(1);
  dropped_source_.fetch_add(1);  // a frame lost, as when the source refuses it
  last_corrupt_ = dec.why();
  if (++bad_in_row_ > kMaxBadInRow)
    status_ = std::to_string(bad_in_row_) + " frames in a row are not decodable JPEG (the last: " + last_corrupt_ +
              "): the camera's stream is damaged (USB bandwidth? cable?)";
}

bool CaptureThread::wait_take_since(Frame& out, double timeout_s, double min_steady_s, double* passed_s) {
  if (passed_s != nullptr) *passed_s = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(std::max(0.0, timeout_s)));
  for (;;) {
    consumer_waiting_ = true;  // a packet arriving now is decoded on the capture thread, for us
    cv_.wait_until(lock, deadline, [&] { return slot_full_ || stop_.load(); });
    consumer_waiting_ = false;
    if (!slot_full_) return false;
    Frame f = std::move(slot_);
    slot_ = Frame{};
    slot_full_ = false;
    if (pending_full_) decode_cv_.notify_one();  // eager: the newest packet, now
    if (f.steady_s < min_steady_s) {  // too old for the caller: passed over
      dropped_consumer_.fetch_add(1);
      if (frame_undecoded(f)) skipped_undecoded_.fetch_add(1);
      if (passed_s != nullptr) *passed_s = std::max(*passed_s, f.steady_s);
      continue;
    }
    if (frame_undecoded(f)) {  // decode on take, on this (the consumer's) thread
      lock.unlock();
      const bool ok = decode(take_decoder_, f);
      lock.lock();
      count_decode(ok, take_decoder_);
      if (!ok) continue;  // dropped and counted: the next one, within the time left
    }
    out = std::move(f);
    return true;
  }
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
      // Without deferral the source decoded (and refused) these; with it, it only checked them.
      if (!source_options_.defer_jpeg_decode) decodes_.fetch_add(c - corrupt_.load());
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
    if (!frame_undecoded(f) && !f.encoded.empty()) decodes_.fetch_add(1);  // decoded by the source
    if (options_.stall_after_frames > 0 && count == options_.stall_after_frames)
      stall_until = f.steady_s + options_.stall_s;
    if (stall_until > 0 && f.steady_s < stall_until) continue;  // the stall test hook
    if (const double prev = last_steady_s_.load(std::memory_order_relaxed); prev > 0 && f.steady_s - prev > options_.silence_s) {
      std::lock_guard<std::mutex> lock(mutex_);
      silence_ = {prev, f.steady_s};
    }
    last_steady_s_.store(f.steady_s, std::memory_order_release);
    delivered_.fetch_add(1);
    if (decode_eager()) {
      bool wake = false;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (pending_full_) {  // superseded before its decode started: never decoded
          dropped_consumer_.fetch_add(1);
          skipped_undecoded_.fetch_add(1);
        }
        if (frame_undecoded(f)) {
          pending_ = std::move(f);
          pending_full_ = true;
          wake = !slot_full_;
        } else {  // decoded by the source (a (re)opened source's first frame): to the slot
          pending_ = Frame{};
          pending_full_ = false;
          if (slot_full_) dropped_consumer_.fetch_add(1);
          slot_ = std::move(f);
          slot_full_ = true;
        }
      }
      if (wake) decode_cv_.notify_one();
      else cv_.notify_one();
      continue;
    }
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (frame_undecoded(f) && consumer_waiting_ && !slot_full_) {
        // The consumer is waiting for this very frame: decode it here, off its thread.
        lock.unlock();
        const bool ok = decode(capture_decoder_, f);
        lock.lock();
        count_decode(ok, capture_decoder_);
        if (!ok) continue;  // dropped and counted; the consumer waits for the next
      }
      if (slot_full_) {
        dropped_consumer_.fetch_add(1);
        if (frame_undecoded(slot_)) skipped_undecoded_.fetch_add(1);
      }
      slot_ = std::move(f);
      slot_full_ = true;
    }
    cv_.notify_one();
  }
}

}  // namespace dentar::ar
