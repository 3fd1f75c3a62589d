// A `dentar live --record` folder as a run reads it back: recording.json
// (how the live run tracked) and frames.csv (per frame: capture time, the
// haptic steps done when it was drawn, the drawn pose's step, the tag
// search's cues). See docs/formats.md "Live recording".
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "dentar/ar/tracker.h"
#include "dentar/volume/result.h"

namespace dentar::session {

// A `dentar live --record` folder (recording.json): footage as frames/,
// capture times and the haptic step each frame was drawn at in frames.csv.
struct Recording {
  bool present = false;
  std::string frames_csv;
  std::vector<double> capture_s;            // per frame index
  std::vector<std::uint64_t> haptic_steps;  // per frame index: engine steps done when it was composited
  std::vector<double> pose_step;            // per frame index: the drawn pose's step (-1: newest); may be empty
  std::string discovery;                    // "inline" or "async"
  // How the live run decoded its images and refined the mirror (absent in
  // recordings older than these fields: the defaults then, srgb and off).
  ar::CameraResponse camera_response = ar::CameraResponse::kSrgb;
  bool mirror_rim = false;
  // TrackerOptions::stereo_mirror_rim of the live run (absent: on, its default since session 16).
  bool stereo_mirror_rim = true;
  // How the live run decoded a Motion JPEG camera's frames (recording.json "jpeg_decode",
  // session 18): "yuyv" (the JPEG's planes as YUYV, live --camera-format auto/mjpg) or "bgr"
  // (absent: "bgr", as every run before it). The replay decodes frames/*.jpg the same way.
  std::string jpeg_decode = "bgr";
  // Poses predicted this far past capture time (live --predict-ms; absent: 0), ms.
  double predict_ms = 0;
  // discovery "async": what the live tracker's full-frame search did at each
  // frame (frames.csv disc_start, disc_merged), replayed with kScheduled.
  std::vector<ar::DiscoveryCue> cues;
  bool cues_exact = true;  // false: a merge names a frame the recording lacks (dropped)
  // A stereo run (issue 28, recording.json "stereo"): both eyes kept, the right eye's images in
  // frames_right/ (frame_NNNNNN.EXT, as frames/), per frame the eyes it had
  // (ar::FrameRecord::kEyes*, frames.csv eyes). stereo_head: "two_cameras" or "side_by_side".
  bool stereo = false;
  std::string stereo_head;
  std::vector<int> eyes;
};

// Reads the folder's recording.json and frames.csv. Errors name the file,
// the field or line, and what is wrong.
Result<Recording> read_recording(const std::filesystem::path& dir);

}  // namespace dentar::session
