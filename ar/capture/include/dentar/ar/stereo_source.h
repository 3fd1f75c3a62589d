// StereoSource: the two eyes of a stereo head as one source of frame pairs (issue 28).
//
// Two forms:
//   open_pair(left, right)   two cameras (two V4L2/UVC specs, camera:N or /dev/videoN, each the
//                            ordinary camera backend of frame_source.h), or two stand-ins
//                            (live:PATH each), or two recorded files/folders;
//   open_side_by_side(spec)  one device (or recording) whose frames hold both eyes side by side,
//                            2W x H: the left eye in columns 0..W-1, the right in W..2W-1
//                            (docs/formats.md, `dentar synth --stereo`). An odd width is refused.
//
// Pairing (two live eyes): each eye runs its own CaptureThread (latest frame wins); a left and a
// right frame are a pair when their capture times (Frame::steady_s, one clock for both) differ
// by at most max_skew_s (default: half a frame period). A frame with no partner within that
// window is dropped and counted (unpaired). Recorded pairs pair by Frame::time_s the same way,
// read in step (nothing is dropped for being slow). A side-by-side frame is its own pair (skew 0).
//
// One eye lost (unplugged, stalled, its file ended): once the eye has delivered nothing for
// single_after_s (default 0.1 s), read() yields the other eye's frames alone (StereoFrame with
// one eye empty: the single-view path), within single_after_s plus one frame period of the
// eye's last frame; pairs resume with the eye's first frame back (its CaptureThread reopens it).
//
// Refused at open, naming both: eyes of different sizes, or rates more than 1 % apart; a live
// eye paired with a recorded one.
// Threads: the eyes' capture threads inside; read()/stats() from one consumer thread.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dentar/ar/capture_thread.h"
#include "dentar/ar/frame_source.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

struct StereoFrame {
  Frame left, right;  // an eye without a frame this time has an empty image
  std::int64_t index = 0;  // 0, 1, ... in delivery order
  double skew_s = 0;       // right minus left capture time (pairs only), s
  bool has_left() const { return !left.image.empty(); }
  bool has_right() const { return !right.image.empty(); }
  bool paired() const { return has_left() && has_right(); }
};

struct StereoSourceOptions {
  FrameSourceOptions source;  // both eyes' camera requests
  double max_skew_s = 0;      // 0: half a frame period
  double single_after_s = 0.1;  // an eye silent this long: single-eye frames from the other
  // Per-eye capture hooks (reopen, the stall hook of the fault tests). Live eyes only.
  CaptureThreadOptions left_capture, right_capture;
  std::string validate() const;  // empty when valid, else names the field
};

// Pairing accounting since open. Skews are |right - left| over the pairs, ms.
struct StereoCaptureStats {
  std::int64_t pairs = 0, left_only = 0, right_only = 0;  // frames read()
  std::int64_t unpaired_left = 0, unpaired_right = 0;     // dropped: no partner within the window
  std::int64_t source_dropped_left = 0, source_dropped_right = 0;      // reported by the eye's source
  std::int64_t consumer_dropped_left = 0, consumer_dropped_right = 0;  // replaced before read (latest wins)
  std::int64_t fallbacks = 0;   // times the source went to single-eye frames
  std::int64_t recoveries = 0;  // times pairs came back after a fallback
  double skew_p50_ms = 0, skew_p95_ms = 0, skew_max_ms = 0;
  // Longest time from the lost eye's last frame to the first single-eye frame, ms.
  double fallback_latency_max_ms = 0;
  std::string summary() const;  // one line, for logs and reports
};

class StereoSource {
 public:
  static Result<std::unique_ptr<StereoSource>> open_pair(const std::string& left_spec,
                                                         const std::string& right_spec,
                                                         const StereoSourceOptions& options = {});
  static Result<std::unique_ptr<StereoSource>> open_side_by_side(const std::string& spec,
                                                                 const StereoSourceOptions& options = {});
  ~StereoSource();
  StereoSource(const StereoSource&) = delete;
  StereoSource& operator=(const StereoSource&) = delete;

  // The next pair (or single-eye frame, see above), waiting up to timeout_s. false: nothing in
  // that time, or the end (ended()), or an error (error() says which).
  bool read(StereoFrame& out, double timeout_s);
  bool ended() const;
  const std::string& error() const { return error_; }
  StereoCaptureStats stats() const;
  int width() const { return width_; }    // one eye, px
  int height() const { return height_; }
  double fps() const { return fps_; }
  bool side_by_side() const { return side_by_side_; }
  std::string description() const;
  // "" when both eyes deliver, else which eye is lost and why.
  std::string status() const;

 private:
  struct Eye;
  StereoSource();
  bool take(Eye& e, Frame& f, double timeout_s);
  bool eye_silent(const Eye& e, double now) const;
  void emit_pair(StereoFrame& out, Frame&& l, Frame&& r);
  void emit_single(StereoFrame& out, Frame&& f, bool left);

  std::unique_ptr<Eye> left_, right_;
  bool side_by_side_ = false, live_ = false;
  int width_ = 0, height_ = 0;
  double fps_ = 30;
  StereoSourceOptions options_;
  double max_skew_s_ = 0;
  std::string error_;
  std::int64_t next_index_ = 0;
  bool in_fallback_ = false;
  StereoCaptureStats counts_;
  std::vector<double> skews_ms_;
};

}  // namespace dentar::ar
