// Footage of a calibration board moved by hand in front of a camera with known intrinsics and
// distortion: the stand-in camera for the live camera step of `dentar calibrate live`
// (`dentar synth --board SPEC`). The board goes through `holds` poses
// (calibration::plan_board_poses: tilted 15-45 degrees, spread over the image), held still
// for hold_s each and moved between them in move_s (smooth in and out, as a hand does; moving
// frames carry motion blur: sub-frames averaged over the exposure). Rendered by the same
// ray-caster as `dentar calibrate camera --simulate` (ar/calib_board.h), so the true lens
// bends every pixel.
//
// Output folder: video.mkv (FFV1, BGR), camera.yaml (the true camera, our camera file),
// board_truth.jsonl (per frame: t_s, hold (-1 while moving), still, T_cam_board), clip.json.
// Units: metres, seconds, pixels.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "dentar/calibration/camera_file.h"
#include "dentar/volume/result.h"

namespace dentar::ar {

struct BoardClipOptions {
  std::string board = "aprilgrid:6x5:24:8:tag36h11";  // ar/calib_board.h spec
  int holds = 16;        // board poses held still
  double hold_s = 2.0;   // each held this long
  double move_s = 1.2;   // moving from one pose to the next
  double fps = 10;
  double shutter = 0.5;  // exposure / frame period (motion blur of moving frames)
  double noise_dn = 2;   // sensor noise, 8-bit DN
  std::uint64_t seed = 1;
  std::string validate() const;
};

struct BoardClipFrame {
  double t_s = 0;
  int hold = -1;  // index of the held pose, -1 while moving
  Eigen::Isometry3d T_cam_board = Eigen::Isometry3d::Identity();
};

// The frames' poses (no rendering): deterministic for the options and camera.
std::vector<BoardClipFrame> plan_board_clip(const calibration::CameraIntrinsics& k,
                                            const BoardClipOptions& options);

struct BoardClipSummary {
  int frames = 0;
  double duration_s = 0;
  double render_s = 0;  // wall time
  std::string video_path;
};

// Renders and writes the clip into out_dir (created). `progress(frame)` may be empty.
Result<BoardClipSummary> write_board_clip(const calibration::CameraIntrinsics& k,
                                          const BoardClipOptions& options, const std::string& out_dir,
                                          const std::function<void(int)>& progress = {});

}  // namespace dentar::ar
