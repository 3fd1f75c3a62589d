#include "dentar/training/lesson_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>
#include <thread>

#include "dentar/haptics/replay.h"
#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/training/learner.h"
#include "dentar/volume/bur.h"

namespace dentar::training {

namespace fs = std::filesystem;
using json = nlohmann::json;
using haptics::TrainingModeKind;

StudentModel StudentModel::passive_hand() {
  StudentModel s;
  s.passive = true;
  s.lag_s = 0.5;
  s.grip_N_per_m = 10;
  s.damping_ratio = 0.3;
  return s;
}

std::string StudentModel::validate() const {
  std::ostringstream os;
  if (!std::isfinite(lag_s) || lag_s < 0 || lag_s > 5)
    os << "student lag = " << lag_s << " s must be in [0, 5]";
  else if (!std::isfinite(noise_mm) || noise_mm < 0 || noise_mm > 20)
    os << "student noise = " << noise_mm << " mm must be in [0, 20]";
  else if (!std::isfinite(noise_tau_s) || noise_tau_s <= 0)
    os << "student noise_tau = " << noise_tau_s << " s must be > 0";
  else if (!std::isfinite(grip_N_per_m) || grip_N_per_m <= 0 || grip_N_per_m > 5000)
    os << "student grip = " << grip_N_per_m << " N/m must be in (0, 5000]";
  else if (!std::isfinite(damping_ratio) || damping_ratio <= 0 || damping_ratio > 5)
    os << "student damping ratio = " << damping_ratio << " must be in (0, 5]";
  else if (!std::isfinite(stray_at_s) || !std::isfinite(stray_s) || !std::isfinite(stray_mm) || stray_s < 0)
    os << "student stray: times and distance must be finite, stray_s >= 0";
  return os.str();
}

Result<std::unique_ptr<SimStudentDevice>> SimStudentDevice::create(
    const haptics::DeviceProfile& profile, const haptics::DeviceLimits& limits, const Eigen::Isometry3d& T_tooth_dev,
    const Eigen::Isometry3d& T_sty_tip, const Eigen::Isometry3d& T_tooth_tip_start, const StudentModel& student,
    bool renders_force, double jitter_s) {
  if (std::string v = student.validate(); !v.empty()) return Error{v};
  if (!std::isfinite(jitter_s) || jitter_s < 0 || jitter_s > 0.01)
    return Error{"jitter = " + std::to_string(jitter_s * 1e3) + " ms must be in [0, 10]"};
  std::unique_ptr<SimStudentDevice> d(new SimStudentDevice());
  d->name_ = renders_force ? "student:" + profile.id : "student:pen";
  d->limits_ = limits;
  d->s_ = student;
  d->T_tooth_dev_ = T_tooth_dev;
  d->T_dev_tooth_ = T_tooth_dev.inverse();
  d->T_sty_tip_ = T_sty_tip;
  d->T_tip_sty_ = T_sty_tip.inverse();
  d->mass_ = profile.tip_mass_kg + 0.1;
  d->k_ = student.grip_N_per_m;
  d->b_ = 2 * student.damping_ratio * std::sqrt(d->k_ * d->mass_);
  d->jitter_ = jitter_s;
  d->renders_ = renders_force;
  d->rng_.seed(student.seed);
  const std::size_t n = static_cast<std::size_t>(std::ceil(student.lag_s / 1e-3)) + 1;
  d->seen_.assign(n, T_tooth_tip_start);
  d->seen_drill_.assign(n, 0);
  d->seen_hand_.assign(n, T_tooth_tip_start.translation());
  d->aim_ = T_tooth_tip_start;
  d->x_ = (d->T_dev_tooth_ * T_tooth_tip_start * d->T_tip_sty_).translation();
  return d;
}

void SimStudentDevice::set_learner(const LearnerHooks& h) noexcept {
  learner_ = h;
  u_.setZero();
}

void SimStudentDevice::see(const Eigen::Isometry3d& T_tooth_expert_tip, bool drilling, double expert_time_s) noexcept {
  seen_[head_] = T_tooth_expert_tip;
  seen_drill_[head_] = drilling ? 1 : 0;
  seen_hand_[head_] = tip_tooth();
  expert_time_ = expert_time_s;
  head_ = (head_ + 1) % seen_.size();
  // The slot to be written next holds the oldest entry: what was seen lag_s ago (the start
  // pose the line was filled with, until lag_s has passed).
  aim_ = seen_[head_];
  aim_drill_ = seen_drill_[head_] != 0;
}

Eigen::Vector3d SimStudentDevice::tip_tooth() const {
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
  T_dev_sty.linear() = (T_dev_tooth_ * aim_ * T_tip_sty_).linear();
  T_dev_sty.translation() = x_;
  return (T_tooth_dev_ * T_dev_sty * T_sty_tip_).translation();
}

bool SimStudentDevice::read(haptics::DeviceState& out) noexcept {
  out.time_s = t_;
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
  T_dev_sty.linear() = (T_dev_tooth_ * aim_ * T_tip_sty_).linear();
  T_dev_sty.translation() = x_;
  out.T_dev_sty = T_dev_sty;
  out.velocity_m_per_s = v_;
  out.pedal = aim_drill_;
  out.buttons = pause_ ? haptics::kButtonSecondary : 0u;
  out.fault = false;
  return true;
}

void SimStudentDevice::write_force(const Eigen::Vector3d& force_dev_N) noexcept {
  if (renders_ && force_dev_N.allFinite()) f_ = force_dev_N;
  else f_.setZero();
  std::uniform_real_distribution<double> uj(0.0, 1.0);
  const double period = 1e-3 + (jitter_ > 0 ? jitter_ * uj(rng_) : 0.0);
  // The aim: the seen tip plus the wander and any stray, as a stylus origin in the device frame.
  std::normal_distribution<double> n01(0.0, 1.0);
  const double a = std::exp(-period / s_.noise_tau_s), sd = s_.noise_mm * 1e-3;
  for (int i = 0; i < 3; ++i) wander_[i] = a * wander_[i] + sd * std::sqrt(1 - a * a) * n01(rng_);
  Eigen::Isometry3d aim = aim_;
  if (learner_.memory) {
    // A learner: its memory of the path at the expert's clock, plus (expert shown) the
    // correction integrated from the error it saw lag_s ago, bounded.
    if (!learner_.recall) {
      u_ += (period / learner_.feedback_tau_s) * (seen_[head_].translation() - seen_hand_[head_]);
      const double un = u_.norm();
      if (un > learner_.feedback_max_m) u_ *= learner_.feedback_max_m / un;
    }
    aim.translation() = learner_.memory->at(expert_time_) + u_;
  }
  aim.translation() += wander_;
  if (t_ >= s_.stray_at_s && t_ < s_.stray_at_s + s_.stray_s && s_.stray_at_s >= 0)
    aim.translation() += Eigen::Vector3d(0, s_.stray_mm * 1e-3, 0);
  const Eigen::Vector3d target = (T_dev_tooth_ * aim * T_tip_sty_).translation();
  constexpr int kSub = 10;
  const double h = period / kSub;
  for (int i = 0; i < kSub; ++i) {
    const Eigen::Vector3d acc = (k_ * (target - x_) - b_ * v_ + f_) / mass_;
    v_ += h * acc;
    x_ += h * v_;
  }
  t_ += period;
}

std::string LessonRunOptions::validate() const {
  if (mode < 1 || mode > 5) return "--mode " + std::to_string(mode) + " must be 1..5 (1 visual replay, 2 passive guidance, 3 active following, 4 force reversal, 5 hints)";
  if (!std::isfinite(seconds) || seconds < 0) return "--seconds must be >= 0";
  if (std::string v = student.validate(); !v.empty()) return v;
  if (learner.memory && (!std::isfinite(learner.feedback_tau_s) || learner.feedback_tau_s < 0.01 ||
                         !std::isfinite(learner.feedback_max_m) || learner.feedback_max_m < 0))
    return "learner: feedback_tau_s must be >= 0.01 s and feedback_max_m >= 0";
  return "";
}

namespace {

struct Rec {
  haptics::SessionLog log;
  haptics::SessionSetup setup;
};

double norm3(const double* f) { return std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]); }

double end_s_hint(const LessonRunOptions& opt, const haptics::ExpertTrack& track) {
  return opt.seconds > 0 ? std::min(opt.seconds, track.duration_s()) : track.duration_s();
}

}  // namespace

Result<LessonRunResult> run_lesson(const Lesson& lesson, const LessonRunOptions& opt) {
  if (std::string v = opt.validate(); !v.empty()) return Error{v};
  LessonRunResult r;
  r.mode_asked = opt.mode;
  r.device = opt.device;
  const bool pen = opt.device == "pen";
  const haptics::DeviceProfile* prof = haptics::find_device_profile(pen ? "touch" : opt.device);
  if (!prof) {
    std::string ids;
    for (const auto& p : haptics::device_profiles()) ids += (ids.empty() ? "" : ", ") + p.id;
    return Error{"--device '" + opt.device + "' is not a device profile (" + ids + ", or pen)"};
  }
  // The recording (load_lesson checked its hash; a lesson built in memory is checked here).
  const std::string rp = fs::absolute(lesson.recording_path()).lexically_normal().string();
  auto log = haptics::read_session_log(rp);
  if (!log) return Error{"the lesson's recording: " + log.error()};
  if (!log->warning.empty()) return Error{"the lesson's recording: " + log->warning};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{rp + ": " + setup.error()};
  auto track = haptics::ExpertTrack::from_records(log->records, setup->engine.T_tooth_dev, setup->engine.T_sty_tip, rp);
  if (!track) return Error{track.error()};
  if (track->content_hash() != lesson.recording_hash)
    return Error{rp + ": not the recording the lesson was made from (content hash differs); make the lesson again"};

  // The mode, and the fallback of a force mode on a device with no force.
  haptics::TrainingParams p = lesson.params;
  int mode = opt.mode;
  if (pen && (mode == 2 || mode == 4)) {
    r.fallback = std::string("the pen stylus renders no force: mode ") + std::to_string(mode) + " (" +
                 haptics::training_mode_name(static_cast<TrainingModeKind>(mode)) +
                 ") falls back to visual guidance, mode 3 (active following: the expert's tool is drawn and "
                 "waits for the student)";
    mode = 3;
    p.conditional_replay = true;
  }
  r.mode_run = mode;
  p.mode = static_cast<TrainingModeKind>(mode);
  p.expert_file = rp;

  haptics::DeviceLimits limits;
  haptics::ForceModelParams model;
  if (Status s = haptics::apply_profile(*prof, {}, limits, model); !s.ok()) return Error{s.error()};
  const double k_max = haptics::guidance_stiffness_limit(limits.max_stiffness_N_per_m);
  if (p.guidance.k_N_per_m > k_max) {
    char b[200];
    std::snprintf(b, sizeof b, "guidance k lowered from %.0f to %.0f N/m (0.4 x %s's contact limit)", p.guidance.k_N_per_m,
                  k_max, prof->id.c_str());
    r.notes.push_back(b);
    p.guidance.k_N_per_m = k_max;
  }
  if (p.guidance.damping_N_s_per_m > limits.max_damping_N_s_per_m) {
    r.notes.push_back("guidance damping lowered to " + prof->id + "'s limit");
    p.guidance.damping_N_s_per_m = limits.max_damping_N_s_per_m;
  }
  r.guidance = p.guidance;
  auto tm = haptics::TrainingMode::create(p, *track);
  if (!tm) return Error{"lesson " + lesson.path + ": " + tm.error()};
  haptics::TrainingMode training = std::move(tm).value();

  auto tooth = make_tooth(lesson.tooth_json);
  if (!tooth) return Error{"lesson " + lesson.path + ": recording.tooth: " + tooth.error()};
  volume::VoxelVolume vol = std::move(tooth).value();
  auto bur = volume::sample_bur(setup->bur, static_cast<std::size_t>(setup->bur_samples));
  if (!bur) return Error{rp + ": bur: " + bur.error()};

  // The student starts 1 mm beside the expert's first pose.
  Eigen::Isometry3d start = track->at(0).T_tooth_tip;
  start.translation() += Eigen::Vector3d(0, 1e-3, 0);
  auto dev = SimStudentDevice::create(*prof, limits, setup->engine.T_tooth_dev, setup->engine.T_sty_tip, start,
                                      opt.student, !pen, opt.jitter_s);
  if (!dev) return Error{dev.error()};
  if (opt.learner.memory) (*dev)->set_learner(opt.learner);
  std::vector<LearnerSample>* trace = opt.learner.trace;
  if (trace) {
    trace->clear();
    trace->reserve(static_cast<std::size_t>(end_s_hint(opt, *track) * 1000 / p.speed) + 16);
  }

  haptics::EngineConfig cfg = setup->engine;
  cfg.model_params = model;
  cfg.try_realtime = false;
  cfg.training = &training;

  std::unique_ptr<haptics::SessionLogWriter> writer;
  if (!opt.out_dir.empty()) {
    std::error_code ec;
    fs::create_directories(opt.out_dir, ec);
    if (ec) return Error{opt.out_dir + ": cannot create: " + ec.message()};
    std::string header;
    {
      auto probe = haptics::Engine::create(cfg, **dev, vol, *bur, nullptr);
      if (!probe) return Error{probe.error()};
      header = (*probe)->header_json(lesson.tooth_json);
    }
    r.session_path = (fs::path(opt.out_dir) / "session.dlog").string();
    haptics::LogWriterOptions lo;
    lo.fsync = false;
    lo.ring_capacity = 1 << 17;
    auto w = haptics::SessionLogWriter::open(r.session_path, header, lo);
    if (!w) return Error{w.error()};
    writer = std::move(w).value();
  }
  auto eng = haptics::Engine::create(cfg, **dev, vol, *bur, writer.get());
  if (!eng) return Error{eng.error()};
  haptics::Engine& engine = **eng;
  SimStudentDevice& student = **dev;

  // The recording's own fastest step (tooth frame), and its pedal by time.
  const auto& recs = log->records;
  const double t0 = recs.front().time_s;
  std::vector<double> rt(recs.size());
  for (std::size_t i = 0; i < recs.size(); ++i) rt[i] = recs[i].time_s - t0;
  for (std::size_t i = 1; i < recs.size(); ++i)
    r.fastest_recorded_step_m = std::max(r.fastest_recorded_step_m, (track->at(rt[i]).T_tooth_tip.translation() -
                                                                     track->at(rt[i - 1]).T_tooth_tip.translation()).norm());
  auto recorded_pedal = [&](double te) {
    std::size_t i = static_cast<std::size_t>(std::upper_bound(rt.begin(), rt.end(), te) - rt.begin());
    i = i == 0 ? 0 : i - 1;
    return recs[i].pedal != 0;
  };

  const double end_s = opt.seconds > 0 ? std::min(opt.seconds, track->duration_s()) : track->duration_s();
  double pause_total = 0;
  for (const Annotation& a : lesson.annotations) pause_total += opt.pauses ? a.pause_s : 0;
  const std::uint64_t cap = static_cast<std::uint64_t>((end_s / p.speed + pause_total + 60.0) * 1000.0);
  const Eigen::Matrix3d R_dev_tooth = setup->engine.T_tooth_dev.linear().transpose();
  const Eigen::Matrix3d R_tooth_dev = setup->engine.T_tooth_dev.linear();
  std::vector<double> err;
  err.reserve(static_cast<std::size_t>(end_s * 1000 / p.speed) + 16);
  double prev_f = 0, prev_expert_time = 0;
  Eigen::Vector3d prev_expert = track->at(0).T_tooth_tip.translation();
  std::size_t next_pause = 0;
  double pause_until = -1, running_since = 0;
  bool was_held = false;
  double released_at = -1, prev_f_for_pause = 0;
  for (std::uint64_t i = 0; i < cap; ++i) {
    if (engine.run_steps(1) != 1) break;
    const haptics::HapticSnapshot s = engine.snapshot();
    ++r.steps;
    const double f = norm3(s.force_dev_N);
    Eigen::Isometry3d Te = Eigen::Isometry3d::Identity();
    for (int c = 0; c < 4; ++c)
      for (int rr = 0; rr < 4; ++rr) Te.matrix()(rr, c) = s.T_tooth_expert_tip[4 * c + rr];
    const Eigen::Vector3d pe = Te.translation();
    if (i == 0) {
      r.first_force_N = f;
      if (mode == 2) r.start_field_N = haptics::guidance_force(pe - student.tip_tooth(), p.guidance).norm();
      if (mode == 4) r.start_field_N = track->at(0).force_N.norm();
    }
    if (i > 0) {
      r.max_step_N = std::max(r.max_step_N, std::abs(f - prev_f));
      if (s.time_s < 0.3) r.start_max_step_N = std::max(r.start_max_step_N, std::abs(f - prev_f));
    }
    prev_f = f;
    r.max_force_N = std::max(r.max_force_N, f);
    r.mean_force_N += f;
    r.max_expert_jump_m = std::max(r.max_expert_jump_m, (pe - prev_expert).norm());
    prev_expert = pe;
    if (s.expert_waiting) r.waited_s += 1e-3;
    if (s.expert_time_s >= 0.5) err.push_back(s.follow_error_m);
    // The expert-drilling flag against the recording's pedal at the expert's time.
    r.drill_steps += s.expert_drilling;
    r.drill_mismatch += (s.expert_drilling != 0) != recorded_pedal(s.expert_time_s);
    // Mode 4: -F once the mode has run unpaused for its ramp.
    const bool held = pause_until >= 0;
    if (held != was_held || s.expert_waiting) running_since = student.time_s();
    if (was_held && !held) released_at = student.time_s();
    if (i > 0 && (held || (released_at >= 0 && student.time_s() - released_at < 0.3)))
      r.pause_max_step_N = std::max(r.pause_max_step_N, std::abs(f - prev_f_for_pause));
    prev_f_for_pause = f;
    was_held = held;
    if (mode == 4 && !held && student.time_s() - running_since > p.ramp_s + 0.01 && s.expert_time_s < end_s) {
      const Eigen::Vector3d want = R_dev_tooth * -track->at(s.expert_time_s).force_N;
      if (want.norm() < limits.max_force_N * 0.99) {
        const Eigen::Vector3d sent(s.force_dev_N[0], s.force_dev_N[1], s.force_dev_N[2]);
        r.reversal_error_N = std::max(r.reversal_error_N, (sent - want).norm());
        ++r.reversal_checked;
      }
    }
    // The lesson's pause points: the student holds the pause button for pause_s.
    if (pause_until >= 0 && student.time_s() >= pause_until) {
      student.hold_pause(false);
      pause_until = -1;
    }
    while (opt.pauses && pause_until < 0 && next_pause < lesson.annotations.size() &&
           lesson.annotations[next_pause].time_s <= s.expert_time_s) {
      const Annotation& a = lesson.annotations[next_pause++];
      if (a.pause_s <= 0) continue;
      student.hold_pause(true);
      if (r.pauses_taken == 0) r.pause_field_N = f;
      pause_until = student.time_s() + a.pause_s;
      r.paused_s += a.pause_s;
      ++r.pauses_taken;
    }
    student.see(Te, s.expert_drilling != 0, s.expert_time_s);
    if (trace) {
      LearnerSample ls;
      ls.expert_time_s = s.expert_time_s;
      ls.expert_tip = pe;
      ls.hand_tip = student.tip_tooth();
      ls.feedback = student.feedback_tooth();
      ls.force_N = R_tooth_dev * Eigen::Vector3d(s.force_dev_N[0], s.force_dev_N[1], s.force_dev_N[2]);
      trace->push_back(ls);
    }
    prev_expert_time = s.expert_time_s;
    if (s.expert_time_s >= end_s && pause_until < 0) break;
    // Keep the log's ring from overflowing: simulated time runs faster than the disk.
    if (writer && (i & 1023) == 0)
      while (r.steps > writer->written() + (1u << 16)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r.expert_end_s = prev_expert_time;
  if (r.steps > 0) r.mean_force_N /= static_cast<double>(r.steps);
  r.stats = engine.stats();
  r.volume_hash = vol.content_hash();
  for (double m : engine.snapshot().removed_mm3) r.removed_mm3 += m;
  if (!err.empty()) {
    r.follow_mean_m = std::accumulate(err.begin(), err.end(), 0.0) / static_cast<double>(err.size());
    std::sort(err.begin(), err.end());
    r.follow_p95_m = err[err.size() * 95 / 100];
    r.follow_max_m = err.back();
  }
  eng->reset();
  if (writer) {
    if (Status s = writer->close(); !s.ok()) return Error{s.error()};
    if (writer->dropped() > 0)
      return Error{r.session_path + ": the log dropped " + std::to_string(writer->dropped()) + " steps (disk too slow)"};
    std::ofstream o(fs::path(opt.out_dir) / "run.json");
    o << lesson_run_json(r);
    if (!o) return Error{(fs::path(opt.out_dir) / "run.json").string() + ": cannot write"};
  }
  return r;
}

std::string lesson_run_json(const LessonRunResult& r) {
  json j = {{"mode_asked", r.mode_asked},
            {"mode", r.mode_run},
            {"mode_name", haptics::training_mode_name(static_cast<TrainingModeKind>(r.mode_run))},
            {"fallback", r.fallback},
            {"notes", r.notes},
            {"device", r.device},
            {"session", r.session_path},
            {"steps", r.steps},
            {"expert_end_s", r.expert_end_s},
            {"follow_error_mm", {{"mean", r.follow_mean_m * 1e3}, {"p95", r.follow_p95_m * 1e3}, {"max", r.follow_max_m * 1e3}}},
            {"expert_waited_s", r.waited_s},
            {"guidance", {{"as_needed", r.guidance.as_needed}, {"across_path_only", r.guidance.across_path_only},
                          {"fade", r.guidance.fade}, {"repetition", r.guidance.repetition},
                          {"amplify", r.guidance.amplify}, {"k_N_per_m", r.guidance.k_N_per_m}}},
            {"pauses", r.pauses_taken},
            {"paused_s", r.paused_s},
            {"force_N", {{"max", r.max_force_N}, {"mean", r.mean_force_N}, {"first_step", r.first_force_N}, {"start_max_step", r.start_max_step_N},
                         {"start_field", r.start_field_N}, {"max_step", r.max_step_N},
                         {"pause_field", r.pause_field_N}, {"pause_max_step", r.pause_max_step_N}}},
            {"reversal_error_N", r.reversal_error_N},
            {"expert_drilling_steps", r.drill_steps},
            {"expert_drilling_mismatch", r.drill_mismatch},
            {"expert_max_jump_mm", r.max_expert_jump_m * 1e3},
            {"recording_fastest_step_mm", r.fastest_recorded_step_m * 1e3},
            {"removed_mm3", r.removed_mm3},
            {"guard_clamped_steps", r.stats.guard_clamped},
            {"guard_rate_limited_steps", r.stats.guard_rate_limited},
            {"watchdog_trips", r.stats.watchdog_trips}};
  char h[17];
  std::snprintf(h, sizeof h, "%016llx", static_cast<unsigned long long>(r.volume_hash));
  j["volume_hash"] = h;
  return j.dump(1) + "\n";
}

}  // namespace dentar::training
