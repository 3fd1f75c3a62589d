// session::LessonClock and the live lesson's simulated student. See lesson_clock.h.
#include "dentar/session/lesson_clock.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "dentar/haptics/device_profiles.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"

namespace dentar::session {
namespace fs = std::filesystem;

Result<std::unique_ptr<LessonClock>> LessonClock::open(const std::string& lesson_arg, int mode,
                                                       const haptics::DeviceLimits& limits, bool renders_force) {
  if (mode < 1 || mode > 5)
    return Error{"--mode " + std::to_string(mode) +
                 " must be 1..5 (1 visual replay, 2 passive guidance, 3 active following, 4 force reversal, 5 hints)"};
  auto path = training::resolve_lesson_path(lesson_arg);
  if (!path) return Error{"--lesson " + lesson_arg + ": " + path.error()};
  auto lesson = training::load_lesson(*path);
  if (!lesson) return Error{"--lesson " + lesson_arg + ": " + lesson.error()};
  std::unique_ptr<LessonClock> c(new LessonClock);
  c->lesson_ = std::move(*lesson);
  // The recording (load_lesson checked its content hash and length).
  const std::string rp = fs::absolute(c->lesson_.recording_path()).lexically_normal().string();
  auto log = haptics::read_session_log(rp);
  if (!log) return Error{"--lesson " + lesson_arg + ": the lesson's recording: " + log.error()};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{rp + ": " + setup.error()};
  auto track = haptics::ExpertTrack::from_records(log->records, setup->engine.T_tooth_dev, setup->engine.T_sty_tip, rp);
  if (!track) return Error{track.error()};
  if (track->content_hash() != c->lesson_.recording_hash)
    return Error{rp + ": not the recording the lesson was made from (content hash differs); make the lesson again"};
  c->track_.emplace(std::move(*track));
  c->bur_ = setup->bur;
  c->bur_samples_ = setup->bur_samples;
  // The mode, and the fallback of a force mode on a stylus with no force.
  haptics::TrainingParams p = c->lesson_.params;
  c->mode_asked_ = mode;
  if (!renders_force && (mode == 2 || mode == 4)) {
    c->fallback_ = std::string("the stylus renders no force: mode ") + std::to_string(mode) + " (" +
                   haptics::training_mode_name(static_cast<haptics::TrainingModeKind>(mode)) +
                   ") falls back to visual guidance, mode 3 (active following: the expert's tool is drawn and "
                   "waits for the student)";
    mode = 3;
    p.conditional_replay = true;
  }
  c->mode_run_ = mode;
  p.mode = static_cast<haptics::TrainingModeKind>(mode);
  p.expert_file = rp;
  // The guidance field within what the device renders stably (the engine refuses more).
  const double k_max = haptics::guidance_stiffness_limit(limits.max_stiffness_N_per_m);
  if (p.guidance.k_N_per_m > k_max) {
    char b[200];
    std::snprintf(b, sizeof b, "guidance k lowered from %.0f to %.0f N/m (0.4 x the device's contact limit)",
                  p.guidance.k_N_per_m, k_max);
    c->notes_.push_back(b);
    p.guidance.k_N_per_m = k_max;
  }
  if (p.guidance.damping_N_s_per_m > limits.max_damping_N_s_per_m) {
    c->notes_.push_back("guidance damping lowered to the device's limit");
    p.guidance.damping_N_s_per_m = limits.max_damping_N_s_per_m;
  }
  auto m = haptics::TrainingMode::create(p, *c->track_);
  if (!m) return Error{"--lesson " + lesson_arg + ": " + m.error()};
  c->mode_.emplace(std::move(*m));
  return c;
}

Result<std::unique_ptr<LessonClock>> LessonClock::from_header(const haptics::TrainingSetup& t) {
  auto tr = haptics::load_trained_expert(t);
  if (!tr) return Error{tr.error()};
  std::unique_ptr<LessonClock> c(new LessonClock);
  c->track_.emplace(std::move(*tr));
  auto m = haptics::TrainingMode::create(t.params, *c->track_);
  if (!m) return Error{m.error()};
  c->mode_.emplace(std::move(*m));
  c->mode_asked_ = c->mode_run_ = static_cast<int>(t.params.mode);
  // The lesson the recording belongs to (lesson.json beside it), for its notes; a recording
  // outside a lesson folder has none.
  const std::filesystem::path dir = std::filesystem::path(t.params.expert_file).parent_path();
  std::error_code ec;
  if (std::filesystem::is_regular_file(dir / training::kLessonFile, ec)) {
    auto l = training::load_lesson(dir.string());
    if (!l)
      c->notes_.push_back("the lesson's notes are not shown: " + l.error());
    else if (l->recording_hash != t.expert_hash)
      c->notes_.push_back("the lesson's notes are not shown: " + (dir / training::kLessonFile).string() +
                          " is for another recording than the session's expert");
    else
      c->lesson_ = std::move(*l);
  }
  return c;
}

bool LessonStudentDevice::read(haptics::DeviceState& out) noexcept {
  if (const haptics::Engine* e = engine_.load(); e != nullptr) {
    const haptics::HapticSnapshot s = e->snapshot();
    if (s.step > 0 && s.mode != 0) {
      Eigen::Isometry3d Te = Eigen::Isometry3d::Identity();
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) Te.matrix()(r, c) = s.T_tooth_expert_tip[4 * c + r];
      s_->see(Te, s.expert_drilling != 0);
    }
  }
  return s_->read(out);
}

LessonPauseDevice::LessonPauseDevice(haptics::HapticDevice& inner, const std::vector<training::Annotation>& annotations)
    : inner_(&inner) {
  for (std::size_t i = 0; i < annotations.size(); ++i)
    if (annotations[i].pause_s > 0) points_.push_back({annotations[i].time_s, annotations[i].pause_s, static_cast<int>(i)});
  std::stable_sort(points_.begin(), points_.end(), [](const Point& a, const Point& b) { return a.time_s < b.time_s; });
}

bool LessonPauseDevice::read(haptics::DeviceState& out) noexcept {
  const bool ok = inner_->read(out);
  const bool down = (out.buttons & haptics::kButtonSecondary) != 0;
  const double t = out.time_s;
  const bool asked = resume_.exchange(false, std::memory_order_acq_rel);  // dropped outside a pause point
  if (until_s_ >= 0) {  // in a pause point: ends after its time, or on a press and release of the button
    if (down && !was_down_) pressed_in_pause_ = true;
    const bool released = pressed_in_pause_ && !down;
    if (t >= until_s_ || released || asked || !std::isfinite(t)) {
      if (released && t < until_s_)
        by_button_.fetch_add(1, std::memory_order_relaxed);
      else if (asked && t < until_s_)
        by_key_.fetch_add(1, std::memory_order_relaxed);
      done_s_ += std::max(0.0, std::min(t, until_s_) - started_s_);
      paused_s_.store(done_s_, std::memory_order_relaxed);
      until_s_ = -1;
      left_s_.store(0, std::memory_order_relaxed);
      pausing_.store(-1, std::memory_order_release);
    } else {
      left_s_.store(until_s_ - t, std::memory_order_relaxed);
      paused_s_.store(done_s_ + (t - started_s_), std::memory_order_relaxed);
    }
  }
  if (until_s_ < 0 && next_ < points_.size() && std::isfinite(t)) {
    if (const haptics::Engine* e = engine_.load(); e != nullptr) {
      const haptics::HapticSnapshot s = e->snapshot();
      if (s.steps_done > 0 && s.mode != 0 && points_[next_].time_s <= s.expert_time_s) {
        const Point& p = points_[next_++];
        until_s_ = t + p.pause_s;
        started_s_ = t;
        pressed_in_pause_ = false;
        taken_.fetch_add(1, std::memory_order_relaxed);
        left_s_.store(p.pause_s, std::memory_order_relaxed);
        pausing_.store(p.annotation, std::memory_order_release);
      }
    }
  }
  was_down_ = down;
  student_.store(down && until_s_ < 0, std::memory_order_relaxed);
  if (until_s_ >= 0) out.buttons |= haptics::kButtonSecondary;
  return ok;
}

Result<haptics::DeviceLimits> lesson_student_limits() {
  const haptics::DeviceProfile* prof = haptics::find_device_profile(kLessonStudentProfile);
  if (!prof) return Error{std::string("device profile ") + kLessonStudentProfile + " is missing from this build"};
  haptics::DeviceLimits limits;
  haptics::ForceModelParams model;
  if (Status s = haptics::apply_profile(*prof, {}, limits, model); !s) return Error{s.error()};
  return limits;
}

Result<std::unique_ptr<LessonStudentDevice>> make_lesson_student(const Eigen::Isometry3d& T_tooth_dev,
                                                                 const Eigen::Isometry3d& T_sty_tip,
                                                                 const Eigen::Isometry3d& T_tooth_expert_start) {
  const haptics::DeviceProfile* prof = haptics::find_device_profile(kLessonStudentProfile);
  auto limits = lesson_student_limits();
  if (!prof || !limits) return Error{limits ? std::string("no device profile") : limits.error()};
  Eigen::Isometry3d start = T_tooth_expert_start;
  start.translation() += Eigen::Vector3d(0, 1e-3, 0);
  auto d = training::SimStudentDevice::create(*prof, *limits, T_tooth_dev, T_sty_tip, start, training::StudentModel{},
                                              true);
  if (!d) return Error{"simulated student: " + d.error()};
  return std::make_unique<LessonStudentDevice>(std::move(*d));
}

}  // namespace dentar::session
