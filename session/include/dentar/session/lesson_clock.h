// A lesson's side of a run (issue 27): the expert's recording as a track, and the training
// mode over it that the engine steps (haptics/guidance.h). Owned by session::Run, which
// hands the mode to its engine (EngineConfig::training), so the mode outlives the engine.
//  - live (`dentar live --lesson LESSON --mode N`): open() loads the lesson, checks its
//    recording, falls back from a force mode (2, 4) to visual guidance (3) on a stylus with
//    no force, and lowers the guidance gains to the device's limits (as `dentar lesson run`);
//  - a replay (`dentar offline` of a lesson's recording): from_header() rebuilds the mode
//    from the session log's training section (as haptics::replay_session).
// LessonStudentDevice: `--stylus sim` with a lesson: training's simulated student
// (SimStudentDevice: reaction lag, aim wander, hand spring) following the expert's tool as
// the engine shows it.
//
// Units SI; poses in the tooth frame. Threads: built on one thread; the mode then runs on
// the engine's thread only.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dentar/haptics/device.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/guidance.h"
#include "dentar/haptics/replay.h"
#include "dentar/training/lesson.h"
#include "dentar/training/lesson_run.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/result.h"

namespace dentar::session {

class LessonClock {
 public:
  // LESSON (a folder, its lesson.json, or builtin:EXERCISE) in mode 1..5 on a stylus whose
  // limits are `limits`; renders_force false (the pen): modes 2 and 4 fall back to 3.
  // Errors are bad input and name the lesson, the file and the field.
  static Result<std::unique_ptr<LessonClock>> open(const std::string& lesson, int mode, const haptics::DeviceLimits& limits,
                                                   bool renders_force);
  // The mode a session log's header recorded (its training section).
  static Result<std::unique_ptr<LessonClock>> from_header(const haptics::TrainingSetup& t);

  LessonClock(const LessonClock&) = delete;
  LessonClock& operator=(const LessonClock&) = delete;

  haptics::TrainingMode* mode() { return &*mode_; }
  const haptics::ExpertTrack& track() const { return *track_; }
  // open(); from_header(): the lesson whose lesson.json lies beside the expert's recording
  // (its notes drawn in a replay), else empty (notes() says why when one was there but refused).
  const training::Lesson& lesson() const { return lesson_; }
  int mode_asked() const { return mode_asked_; }
  int mode_run() const { return mode_run_; }
  const std::string& fallback() const { return fallback_; }   // why mode_run differs ("" = it does not)
  const std::vector<std::string>& notes() const { return notes_; }  // gains lowered, etc.
  // The recording's bur (the expert's tool is drawn and cuts with it) and its first tip pose.
  const volume::BurParams& bur() const { return bur_; }
  int bur_samples() const { return bur_samples_; }
  Eigen::Isometry3d expert_start() const { return track_->at(0).T_tooth_tip; }

 private:
  LessonClock() = default;
  training::Lesson lesson_;
  std::optional<haptics::ExpertTrack> track_;
  std::optional<haptics::TrainingMode> mode_;
  int mode_asked_ = 0, mode_run_ = 0;
  std::string fallback_;
  std::vector<std::string> notes_;
  volume::BurParams bur_ = volume::BurParams::capsule(0.5, 3.0);
  int bur_samples_ = 10000;
};

// The simulated student of a live lesson: each read first shows the student the expert's
// tool of the engine's last step (its snapshot: lock-free, on the engine's own thread), as
// `dentar lesson run` shows it after each step. attach() the engine before it starts.
class LessonStudentDevice final : public haptics::HapticDevice {
 public:
  explicit LessonStudentDevice(std::unique_ptr<training::SimStudentDevice> student) : s_(std::move(student)) {}
  void attach(const haptics::Engine* engine) { engine_.store(engine); }
  std::string name() const override { return s_->name(); }
  const haptics::DeviceLimits& limits() const override { return s_->limits(); }
  bool read(haptics::DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& force_dev_N) noexcept override { s_->write_force(force_dev_N); }

 private:
  std::unique_ptr<training::SimStudentDevice> s_;
  std::atomic<const haptics::Engine*> engine_{nullptr};
};

// A lesson's pause points, live (docs/training_modes.md): in front of the engine's device, it
// holds the stylus's pause button (kButtonSecondary) from the moment the expert's clock
// reaches a pause point (the engine's snapshot: lock-free) for the point's pause_s of device
// time, or until the student presses and releases the pause button (or asks by
// request_resume), whichever comes first.
// The engine pauses the mode while the button is down (its clock stops, the mode's force fades
// out over ramp_s and back in: no jump), and the held button is what the session log
// records, so a replay repeats the pause bit-exactly, as `dentar lesson run`'s simulated
// student holds it offline. read() runs on the engine's thread: no allocation, lock or wait
// (the pause points are copied at construction). The figures are atomics for the HUD.
class LessonPauseDevice final : public haptics::HapticDevice {
 public:
  LessonPauseDevice(haptics::HapticDevice& inner, const std::vector<training::Annotation>& annotations);
  void attach(const haptics::Engine* engine) { engine_.store(engine); }
  std::string name() const override { return inner_->name(); }
  const haptics::DeviceLimits& limits() const override { return inner_->limits(); }
  bool read(haptics::DeviceState& out) noexcept override;
  void write_force(const Eigen::Vector3d& f) noexcept override { inner_->write_force(f); }
  bool recorded_watchdog() const noexcept override { return inner_->recorded_watchdog(); }
  std::string status() const override { return inner_->status(); }

  // The annotation whose pause holds the clock now (-1: none) and the seconds it has left.
  int pausing() const { return pausing_.load(std::memory_order_acquire); }
  double pause_left_s() const { return left_s_.load(std::memory_order_relaxed); }
  int pauses_taken() const { return taken_.load(std::memory_order_relaxed); }
  double paused_s() const { return paused_s_.load(std::memory_order_relaxed); }  // device time held, all pauses
  int resumed_by_button() const { return by_button_.load(std::memory_order_relaxed); }
  // Pause points ended early by request_resume (a key of the window).
  int resumed_by_key() const { return by_key_.load(std::memory_order_relaxed); }
  // The student's own pause: the stylus's pause button held outside a pause point (the
  // engine holds the expert's clock while it is down).
  bool student_holding() const { return student_.load(std::memory_order_relaxed); }
  // Ends the pause point holding the clock now at the next read, as a press and release of
  // the pause button would: for the pen stylus, which has no button (a key of the window).
  // Any thread (an atomic flag); a request outside a pause point is dropped.
  void request_resume() { resume_.store(true, std::memory_order_release); }

 private:
  struct Point {
    double time_s, pause_s;
    int annotation;
  };
  haptics::HapticDevice* inner_;
  std::vector<Point> points_;  // pause points by time; read-only once built
  std::atomic<const haptics::Engine*> engine_{nullptr};
  // The engine's thread only:
  std::size_t next_ = 0;
  double until_s_ = -1, started_s_ = 0, done_s_ = 0;
  bool was_down_ = false, pressed_in_pause_ = false;
  // Published:
  std::atomic<int> pausing_{-1}, taken_{0}, by_button_{0}, by_key_{0};
  std::atomic<bool> student_{false}, resume_{false};
  std::atomic<double> left_s_{0}, paused_s_{0};
};

// The simulated student of a live lesson is on the "touch" device profile (its limits and
// plant, as `dentar lesson run`'s default): its limits, and the student starting 1 mm beside
// the expert's first pose.
inline constexpr const char* kLessonStudentProfile = "touch";
Result<haptics::DeviceLimits> lesson_student_limits();
Result<std::unique_ptr<LessonStudentDevice>> make_lesson_student(const Eigen::Isometry3d& T_tooth_dev,
                                                                 const Eigen::Isometry3d& T_sty_tip,
                                                                 const Eigen::Isometry3d& T_tooth_expert_start);

}  // namespace dentar::session
