// `dentar calibrate live`: the instructor's live station calibration in a window, every step:
//  - camera: the live video with the board detection, a coverage / trust map of the image and
//    the place the next view is needed; a view is taken by key or pedal and refused with the
//    reason (not found, wrong board, moving, blurred, too similar); RMS and the 1-sigma of fx fy
//    cx cy after each view (calibration/guided.h LiveCameraViews); the model selection of
//    camera_model.h runs beside the window and decides at the end;
//  - pivot (stops itself when the tip is known to 0.2 mm), register (the mannequin's divots in a
//    guided order, FRE and predicted TRE after each touch), tooth (the tooth's landmarks),
//    mirror (8 rim points and the centre, the mirror's pose tracked at each touch), check
//    (known points: the error at each, PASS/FAIL against the station's threshold).
// A touch is taken by the space bar, Enter, the foot pedal or a stylus button, and refused
// when the stylus moved during it. The station file is written once, at the end, only when
// every step passed (a failed check is written too, dated, as `dentar calibrate all`).
//
//   device (HD | DHD | simulated instructor) ──1 kHz poller, zero force──▶ latest pose
//   camera (CaptureThread) ──latest frame──▶ board detection (camera step) ──▶ window background
//   main thread: HudWindow (GLFW + ImGui), step bookkeeping (calibration/guided.h)
//
// `--device sim` is the simulated instructor: a SimulatedDevice whose hand follows an
// instructor's motions toward a hidden truth (the station perturbed by --seed, as
// `dentar calibrate --simulate`), and whose key presses are scripted on what the HUD shows (one
// deliberately while the stylus still moves, one while the board still moves, to show the
// refusals); the board is the camera's footage (`dentar synth --board`: a hand-held board at
// human pace). The step times are those of a calm instructor (docs/BENCHMARKS.md).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "dentar/ar/capture_thread.h"
#include "dentar/calibration/intrinsics.h"
#include "dentar/volume/result.h"

namespace dentar::live {

struct CalibrateLiveOptions {
  std::string station = "station.json";  // read when it exists (else the built-in default) and written
  std::string camera;                    // FrameSource spec shown behind the HUD; empty = no video
  std::string device = "sim";            // "sim" or a haptics::open_haptic_device kind
  std::string device_name;
  std::string pedal = "keyboard";  // keyboard, or a haptics::open_pedal spec (a press takes a touch)
  std::vector<std::string> steps = {"pivot", "register", "tooth"};
  // camera step: the printed board (ar/calib_board.h spec) and the views after which the step
  // may stop itself (when the model is trusted over the image).
  std::string board = "aprilgrid:6x5:24:8:tag36h11";
  int camera_views = 12;
  std::uint64_t seed = 1;  // sim: the hidden truth and the instructor's hand
  double pace = 1.0;       // sim: instructor's travel speed (1 = human pace); holds stay real
  double seconds = 0;      // give up after this long (0 = no limit)
  std::string screenshot_dir;  // the window as PNG at the end of each step (<step>.png)
  std::string summary_path;    // summary JSON
  int display = -1;
  bool vsync = true;
  bool quiet = false;
  std::string validate() const;
};

struct CalibrateLiveStep {
  std::string step;
  bool pass = false;
  double seconds = 0;  // instructor time: step start to step done
  int items = 0;       // poses kept (pivot) or touches taken
  int refused = 0;     // touches refused
  std::vector<std::pair<std::string, double>> figures;
  std::string message;
};

struct CalibrateLiveSummary {
  std::vector<CalibrateLiveStep> steps;
  bool written = false;
  std::string stop_reason;
  double total_s = 0;
  // --device sim: the result against the hidden truth, mm (-1 when not computed).
  double truth_tip_error_mm = -1;      // |p_tip - true p_tip|
  double truth_tooth_error_mm = -1;    // the calibrated chain's error at the crown (tooth frame point 4 mm up)
  double truth_static_colocation_mean_mm = -1, truth_static_colocation_p99_mm = -1;  // bur tip vs tooth, working poses
  // camera step on footage with a camera.yaml beside it (`dentar synth --board`): the chosen
  // model against the true camera, px (-1 when not computed): fx, and the worst projection
  // error over the whole image and over the tooth region (after the best ray rotation).
  double truth_camera_fx_error_px = -1, truth_camera_max_px = -1, truth_camera_tooth_max_px = -1;
  std::vector<std::string> log;  // what the HUD said, in order
  std::string json() const;
};

// Errors (exit 2 at the CLI): bad options, unreadable station, no display, no device.
// A step that does not pass is not an error: summary.written is false and the step says why.
Result<CalibrateLiveSummary> run_calibrate_live(const CalibrateLiveOptions& options);

// ---- `dentar calibrate stereo --live` (issue 28): the captures of a live stereo head ----
// The eyes as one ar::StereoSource (two cameras paired by capture time, or one side-by-side
// device). Every frame is searched for the board in both eyes (one ar::BoardDetector per eye,
// any board kind); a capture is taken by itself when the left eye has seen the board still for
// the still window and the view is new against the captures so far (calibration/guided.h
// LiveCameraViews: the camera step's gates; refusals said only when they change); the right
// eye's view goes with it when the right eye saw the board still too, else the capture serves
// the left eye's intrinsics only (as a photo where one eye misses it). Stops at `count`
// captures, at the source's end, after `seconds`, or when an eye of a live head (camera:N,
// /dev/videoN, live:FILE) has delivered nothing for stall_timeout_s (unplugged, stalled): then
// `stall` says which eye, for how long and what to do, and the captures taken so far are
// returned with it (the caller calibrates them, as after a time limit). No wait is unbounded:
// before this, a camera that stopped delivering kept `--live` without `--seconds` waiting
// forever.
struct StereoLiveOptions {
  std::string left, right;   // two cameras: frame_source.h specs (or recorded videos / frame folders)
  std::string side_by_side;  // or one device delivering both eyes side by side (left | right)
  std::string board = "chessboard:9x6:20";  // ar/calib_board.h spec
  int count = 15;                           // captures wanted, 1..500
  double seconds = 0;                       // give up after this long, s (0 = no limit)
  double stall_timeout_s = 5;               // an eye silent this long ends the capture, s (> 0)
  // Test hooks (the fault tests): each live eye's capture options (the stall hook).
  ar::CaptureThreadOptions left_capture, right_capture;
  std::function<void(const std::string&)> say;  // progress lines, as printed by the CLI (may be empty)
  std::string validate() const;                 // empty when valid, else names the field
};

struct StereoLiveCaptures {
  // One entry per capture in each (names "live-capture-N"); a right view without points: the
  // right eye did not see the board still at that capture.
  std::vector<calibration::BoardView> left, right;
  int width = 0, height = 0;  // one eye, px
  int frames = 0;             // frames read (pairs and single-eye frames)
  // "captures taken", "time limit", "footage ended" or "stall".
  std::string stop_reason;
  std::string stall;    // stop_reason "stall": which eye, for how long, what to do
  std::string pairing;  // the source's pairing summary (ar::StereoCaptureStats::summary)
};

// true for a live camera spec (camera:N, /dev/videoN, live:FILE), as opposed to a recording.
bool is_live_camera_spec(const std::string& spec);

// Errors (bad input, exit 2 at the CLI), each naming the input: options (validate), the eyes
// cannot be opened or disagree (size, rate), the board spec, a source error mid-run; no capture
// taken at all (why: the board never seen still and new by the left eye, or the stall).
Result<StereoLiveCaptures> capture_stereo_live(const StereoLiveOptions& options);

}  // namespace dentar::live
