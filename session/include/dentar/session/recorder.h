// The live recording's writer thread (owned by session::Run): every processed
// camera frame as a file, then its row of frames.csv, and the text log.
//
// Frame files (frames/frame_NNNNNN.EXT, docs/formats.md "live recording"):
//  - .jpg: the camera's own Motion JPEG bytes, written as they came
//    (Frame::encoded): no encoding cost, and decoding them again gives the
//    very pixels the live run tracked;
//  - .png: lossless, for sources without JPEG bytes (raw webcams, FFV1
//    stand-ins), zlib level 1;
//  - .ppm: lossless and uncompressed, written instead of PNG while the writer
//    is behind (PNG costs ~100-200 ms a 720p frame on one core; the writer
//    must keep up with the camera or frames are lost).
// A stereo run (issue 28) keeps both eyes: the right eye's image of frame N
// in frames_right/frame_NNNNNN.EXT by the same rules (its own camera's JPEG
// bytes, else PNG/PPM), only for the frames that had one (frames.csv `eyes`
// "both"; "left" = the right eye was lost, no file).
// A row never names a frame that is not on disk (files written under a
// temporary name, renamed, then the row, flushed per frame). Only when the
// writer is more than kMaxQueued frames behind is a frame not written; it is
// counted (recording.json frames_not_written), and offline replay refuses
// the gap with a message saying so.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <string>
#include <thread>

#include "dentar/ar/frame_pipeline.h"
#include "dentar/volume/result.h"

namespace dentar::session {

class Recorder {
 public:
  // Frames queued beyond this are not written (a memory bound: ~240 MB at 720p).
  static constexpr std::size_t kMaxQueued = 90;
  // Queue depth from which frames without JPEG bytes are written as PPM.
  static constexpr std::size_t kFastFromQueued = 8;

  // stereo (issue 28): frames.csv gets the eyes column (frames_csv.h); frames/ keeps the left
  // eye, frames_right/ the right.
  static Result<std::unique_ptr<Recorder>> open(const std::filesystem::path& dir, bool stereo = false);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Frame thread. `raw` is the frame as tracked (BGR), `encoded` its camera
  // JPEG bytes or empty. Stereo: `right_raw` the right eye's image as tracked
  // (empty: none this frame), `right_encoded` its camera's JPEG bytes or empty.
  // Never blocks on the disk.
  void push(const cv::Mat& raw, const cv::Mat& encoded, const ar::FrameRecord& rec, std::int64_t index,
            std::int64_t source_index, double steady_s, const cv::Mat& right_raw = {},
            const cv::Mat& right_encoded = {});
  void log(const std::string& line);
  // Writes what is queued, then joins the thread.
  void close();

  std::int64_t written() const { return written_.load(); }
  std::int64_t dropped() const { return dropped_.load(); }
  // Frames written per file type (the left eye's; frames_right/: the right eye's).
  std::int64_t written_jpg() const { return n_jpg_.load(); }
  std::int64_t written_png() const { return n_png_.load(); }
  std::int64_t written_ppm() const { return n_ppm_.load(); }
  std::int64_t written_right_jpg() const { return n_right_jpg_.load(); }
  std::int64_t written_right_png() const { return n_right_png_.load(); }
  std::int64_t written_right_ppm() const { return n_right_ppm_.load(); }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  struct Item {
    cv::Mat raw, encoded, right_raw, right_encoded;
    ar::FrameRecord rec;
    std::int64_t index = 0, source_index = 0;
    double steady_s = 0;
  };
  Recorder() = default;
  void main();
  bool write_frame(const Item& it, std::size_t behind);
  // One image as frames_dir/frame_NNNNNN.EXT; the extension written, or empty on failure.
  std::string write_image(const std::filesystem::path& frames_dir, std::int64_t index, const cv::Mat& raw,
                          const cv::Mat& encoded, std::size_t behind);

  std::filesystem::path dir_;
  bool stereo_ = false;
  std::ofstream csv_, log_;
  std::mutex m_;
  std::condition_variable cv_;
  std::deque<Item> q_;
  bool stop_ = false;
  std::atomic<std::int64_t> written_{0}, dropped_{0}, n_jpg_{0}, n_png_{0}, n_ppm_{0};
  std::atomic<std::int64_t> n_right_jpg_{0}, n_right_png_{0}, n_right_ppm_{0};
  std::thread thread_;
};

}  // namespace dentar::session
