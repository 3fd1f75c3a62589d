#include "dentar/haptics/engine.h"

#include <pthread.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <chrono>
#include <nlohmann/json.hpp>
#include <sstream>

namespace dentar::haptics {
namespace {

double now_s() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

void to_array(const Eigen::Isometry3d& T, double out[16]) {
  Eigen::Map<Eigen::Matrix4d> m(out);
  m = T.matrix();
}

// Row-major 4x4, full double precision (nlohmann prints round-trip digits).
nlohmann::json iso_json(const Eigen::Isometry3d& T) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) j.push_back(T.matrix()(r, c));
  return j;
}

}  // namespace

std::string EngineConfig::validate() const {
  std::ostringstream os;
  if (!std::isfinite(rate_hz) || rate_hz < 100 || rate_hz > 10000)
    os << "rate_hz = " << rate_hz << " must be in [100, 10000]";
  else if (model != "seed" && model != "proxy")
    os << "model = '" << model << "' must be 'seed' or 'proxy'";
  else if (watchdog_missed_deadlines < 1)
    os << "watchdog_missed_deadlines = " << watchdog_missed_deadlines << " must be >= 1";
  else if (watchdog_rearm_steps < 0)
    os << "watchdog_rearm_steps = " << watchdog_rearm_steps << " must be >= 0";
  else if (!std::isfinite(max_force_rate_N_per_s) || max_force_rate_N_per_s <= 0)
    os << "max_force_rate_N_per_s = " << max_force_rate_N_per_s << " must be > 0";
  else if (!T_tooth_dev.matrix().allFinite())
    os << "T_tooth_dev has non-finite entries";
  else if (!T_sty_tip.matrix().allFinite())
    os << "T_sty_tip has non-finite entries";
  else if (std::string c = cut.validate(); !c.empty())
    os << "cut." << c;
  return os.str();
}

Result<std::unique_ptr<Engine>> Engine::create(const EngineConfig& cfg, HapticDevice& device,
                                               volume::VoxelVolume& volume,
                                               const volume::BurSamples& bur,
                                               SessionLogWriter* log) {
  if (std::string e = cfg.validate(); !e.empty()) return Error{"engine config: " + e};
  if (std::string e = device.limits().validate(); !e.empty())
    return Error{"device '" + device.name() + "' limits: " + e};
  if (bur.size() == 0) return Error{"engine: the bur has no sample points"};
  if (cfg.training) {
    // A guidance field is a virtual spring and damper: the device's stable limits hold.
    const GuidanceParams& g = cfg.training->params().guidance;
    const DeviceLimits& l = device.limits();
    const double k_max = guidance_stiffness_limit(l.max_stiffness_N_per_m);
    if (g.k_N_per_m > k_max)
      return Error{"training mode: guidance stiffness " + std::to_string(static_cast<int>(g.k_N_per_m)) +
                   " N/m is above what '" + device.name() + "' renders stably as guidance (" +
                   std::to_string(static_cast<int>(k_max)) +
                   " N/m: 0.4 x its contact stiffness limit, docs/training_modes.md); lower k"};
    if (g.damping_N_s_per_m > l.max_damping_N_s_per_m)
      return Error{"training mode: guidance damping " + std::to_string(g.damping_N_s_per_m) + " N s/m is above what '" +
                   device.name() + "' renders stably (" + std::to_string(l.max_damping_N_s_per_m) +
                   " N s/m); lower it"};
  }
  auto model = make_force_model(cfg.model, cfg.model_params, device.limits(), bur.size());
  if (!model) return Error{"engine: " + model.error()};
  return std::unique_ptr<Engine>(
      new Engine(cfg, device, volume, bur, log, std::move(model).value()));
}

Engine::Engine(const EngineConfig& cfg, HapticDevice& device, volume::VoxelVolume& volume,
               const volume::BurSamples& bur, SessionLogWriter* log,
               std::unique_ptr<ForceModel> model)
    : cfg_(cfg),
      device_(&device),
      volume_(&volume),
      bur_(&bur),
      log_(log),
      model_(std::move(model)),
      cutter_(volume, cfg.cut),
      guard_({device.limits().max_force_N, cfg.max_force_rate_N_per_s}),
      dt_s_(1.0 / cfg.rate_hz) {}

Engine::~Engine() { stop(); }

bool Engine::step(double late_s, bool in_thread) noexcept {
  const double t0 = now_s();
  DeviceState st;
  const bool ok = device_->read(st);
  if (!ok && !st.fault) return false;  // replayed source ended

  std::uint8_t flags = 0;
  // Watchdog on deadlines (real-time mode passes how late this step is).
  if (late_s > dt_s_) {
    ++stats_.missed_deadlines;
    if (++consecutive_missed_ >= cfg_.watchdog_missed_deadlines && !watchdog_tripped_) {
      watchdog_tripped_ = true;
      ++stats_.watchdog_trips;
    }
  } else {
    consecutive_missed_ = 0;
  }
  if (watchdog_tripped_ && consecutive_missed_ == 0 && ++good_since_trip_ > cfg_.watchdog_rearm_steps) {
    watchdog_tripped_ = false;
    good_since_trip_ = 0;
  }

  const bool finite = st.T_dev_sty.matrix().allFinite() && st.velocity_m_per_s.allFinite() &&
                      std::isfinite(st.time_s);
  const bool fault = st.fault || !ok || !finite;
  if (fault) {
    ++stats_.device_faults;
    flags |= kFlagDeviceFault;
  }

  ForceOutput out;
  volume::CutResult cut;
  Eigen::Vector3d f_dev = Eigen::Vector3d::Zero();
  const Eigen::Isometry3d T_tooth_sty = cfg_.T_tooth_dev * st.T_dev_sty;
  const Eigen::Isometry3d T_tooth_tip = T_tooth_sty * cfg_.T_sty_tip;
  TrainingStep train;  // defaults: no mode (contact on, the student cuts)
  if (!fault && cfg_.training) {
    cfg_.training->set_held((st.buttons & kButtonSecondary) != 0);
    train = cfg_.training->step(T_tooth_tip, cfg_.T_tooth_dev.linear() * st.velocity_m_per_s, dt_s_);
  }
  if (!fault) {
    ForceInput in;
    in.volume = volume_;
    in.bur = bur_;
    in.T_tooth_tip = T_tooth_tip;
    in.velocity_m_per_s = cfg_.T_tooth_dev.linear() * st.velocity_m_per_s;
    in.dt_s = dt_s_;
    // The model runs in every mode so that its proxy keeps up with the tip; a mode that
    // turns contact off fades its force out (and in again when it ends): no kick.
    out = model_->compute(in);
    contact_gain_.set_target(train.contact_forces ? 1.0 : 0.0);
    const double gain = contact_gain_.step(dt_s_);
    if (st.pedal && train.student_cuts) {
      cut = cutter_.step(*bur_, out.T_tooth_tip_cut, out.force_N.norm(), dt_s_);
      if (cut.touched_pulp) flags |= kFlagPulpTouched;
    }
    if (train.expert_cuts) {
      // The expert's bur cuts where the recording drilled, as long as its clock moved.
      const volume::CutResult ec =
          cutter_.step(*bur_, train.expert.T_tooth_tip, train.expert.force_N.norm(), train.expert_cut_dt_s);
      if (ec.touched_pulp) flags |= kFlagPulpTouched;
      if (cut.total_removed() == 0) cut = ec;
    }
    f_dev = cfg_.T_tooth_dev.linear().transpose() * (gain * out.force_N + train.force_tooth_N);
    if (out.in_contact && gain > 0) flags |= kFlagContact;
  }

  Eigen::Vector3d sent;
  const bool watchdog = watchdog_tripped_ || device_->recorded_watchdog();
  if (fault || watchdog) {
    sent = guard_.zero();
    if (watchdog) flags |= kFlagWatchdog;
  } else {
    const auto clamped0 = guard_.clamped_steps() + guard_.rate_limited_steps();
    sent = guard_.apply(f_dev, dt_s_);
    if (guard_.clamped_steps() + guard_.rate_limited_steps() != clamped0) flags |= kFlagClamped;
    if (guard_.fault() != GuardFault::kNone) flags |= kFlagDeviceFault;
  }
  device_->write_force(sent);
  // The seed model smooths over the forces actually rendered (after the
  // guard); tell it what was sent, in the tooth frame.
  if (!fault) model_->set_rendered_force(cfg_.T_tooth_dev.linear() * sent);

  // Publish for graphics.
  HapticSnapshot snap;
  snap.step = step_index_;
  snap.steps_done = step_index_ + 1;
  snap.time_s = st.time_s;
  to_array(fault ? T_tooth_tip : out.T_tooth_tip_display, snap.T_tooth_tip_display);
  to_array(st.T_dev_sty, snap.T_dev_sty);
  for (int a = 0; a < 3; ++a) snap.force_dev_N[a] = sent[a];
  snap.contacts = out.contacts;
  snap.pedal = st.pedal;
  snap.in_contact = out.in_contact;
  snap.fault = fault;
  snap.watchdog = watchdog_tripped_;
  if (cut.touched_pulp && (st.pedal || train.expert_cuts) && !pulp_exposed_) {
    pulp_exposed_ = true;
    pulp_exposed_at_s_ = st.time_s;
  }
  snap.pulp_exposed = pulp_exposed_;
  if (cfg_.training) {
    snap.mode = static_cast<std::uint8_t>(cfg_.training->params().mode);
    snap.expert_drilling = train.expert.drilling;
    snap.expert_waiting = train.expert_waiting;
    snap.expert_time_s = train.expert_time_s;
    to_array(train.expert.T_tooth_tip, snap.T_tooth_expert_tip);
    snap.follow_error_m = train.error.position_m;
  }
  snap.pulp_exposed_at_s = pulp_exposed_at_s_;
  // The totals change only on steps that removed something.
  if (cut.total_removed() > 0) {
    const volume::CutMetrics m = cutter_.metrics();
    for (int i = 0; i < 8; ++i) removed_mm3_[i] = m.removed_mm3[static_cast<std::size_t>(i)];
  }
  for (int i = 0; i < 8; ++i) snap.removed_mm3[i] = removed_mm3_[i];
  snapshot_.store(snap);
  pose_history_.push(in_thread ? t0 : st.time_s, st.T_dev_sty, !fault);

  // Record.
  if (log_) {
    StepRecord r;
    r.step = step_index_;
    r.time_s = st.time_s;
    for (int a = 0; a < 3; ++a) {
      r.position_m[a] = st.T_dev_sty.translation()[a];
      r.velocity_m_per_s[a] = st.velocity_m_per_s[a];
      r.force_dev_N[a] = sent[a];
    }
    for (int rr = 0; rr < 3; ++rr)
      for (int c = 0; c < 3; ++c) r.rotation[rr * 3 + c] = st.T_dev_sty.linear()(rr, c);
    r.buttons = st.buttons;
    r.contacts = out.contacts;
    for (int i = 0; i < 8; ++i) r.removed[i] = cut.removed[static_cast<std::size_t>(i)];
    r.pedal = st.pedal;
    r.bur_id = cfg_.bur_id;
    r.flags = flags;
    log_->push(r);
  }
  ++step_index_;
  ++stats_.steps;
  steps_published_.store(stats_.steps, std::memory_order_relaxed);
  stats_.compute.record(now_s() - t0);
  return true;
}

std::uint64_t Engine::run_steps(std::uint64_t n, double late_s) {
  if (running()) return 0;
  std::uint64_t done = 0;
  while (done < n && step(late_s, false)) ++done;
  return done;
}

bool realtime_available(int priority, std::string* why) {
  int rc = -1;
  std::thread probe([&rc, priority] {
    sched_param sp{};
    sp.sched_priority = priority;
    rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
  });
  probe.join();
  if (rc != 0 && why != nullptr) *why = std::strerror(rc);
  return rc == 0;
}

Status Engine::start() {
  if (running()) return Error{"engine: already running"};
  if (thread_.joinable()) thread_.join();
  stop_.store(false);
  finished_.store(false);
  running_.store(true, std::memory_order_release);
  tid_.store(-1, std::memory_order_release);
  monitor_.reset();
  monitor_note_.clear();
  if (cfg_.monitor_wakes && cfg_.cpu >= 0) monitor_ = std::make_unique<WakeMonitor>();
  thread_ = std::thread([this] { thread_main(); });
  if (monitor_) {
    // The monitor needs the engine thread's id (published before its first step).
    int tid = -1;
    for (int i = 0; i < 2000 && (tid = tid_.load(std::memory_order_acquire)) < 0 && running(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (tid < 0) {
      monitor_note_ = "the engine thread did not start within 2 s: late wake-ups not attributed";
    } else if (Status s = monitor_->start(tid, cfg_.cpu); !s) {
      monitor_note_ = s.error() + ": late wake-ups not attributed";
    }
  }
  return {};
}

void Engine::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  if (monitor_) {
    monitor_->stop();  // attributes what the engine pushed before it stopped
    stats_.wake = monitor_->stats();
    if (!monitor_note_.empty()) stats_.wake.note = monitor_note_;
    monitor_.reset();
  }
  running_.store(false, std::memory_order_release);
}

namespace {
// Touches `bytes` of this thread's stack so its pages are mapped (and locked,
// under mlockall) before the first step.
__attribute__((noinline)) void prefault_stack(std::size_t bytes) {
  if (bytes == 0) return;
  volatile unsigned char* p = static_cast<volatile unsigned char*>(__builtin_alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += 4096) p[i] = 0;
}
}  // namespace

void Engine::thread_main() {
  pthread_setname_np(pthread_self(), "dentar-engine");  // apart from the main thread in per-thread CPU figures
  if (cfg_.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cfg_.cpu, &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
    stats_.cpu_pinned = rc == 0;
    if (rc != 0)
      stats_.realtime_note += std::string("pinning to CPU ") + std::to_string(cfg_.cpu) +
                              " refused: " + std::strerror(rc) + "; ";
  }
  prefault_stack(cfg_.prefault_stack_bytes);
  if (cfg_.try_realtime) {
    sched_param sp{};
    sp.sched_priority = cfg_.realtime_priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    stats_.realtime_granted = rc == 0;
    if (rc != 0)
      stats_.realtime_note += std::string("SCHED_FIFO refused: ") + std::strerror(rc) +
                             " (run as root or grant CAP_SYS_NICE / an rtprio limit)";
  } else {
    stats_.realtime_note += "real-time priority not requested";
  }
  rt_granted_.store(stats_.realtime_granted, std::memory_order_release);
  cpu_pinned_.store(stats_.cpu_pinned, std::memory_order_release);
  tid_.store(static_cast<int>(::gettid()), std::memory_order_release);
  const double monitor_from_s = monitor_ ? monitor_->late_threshold_s() : 1e300;
  std::int64_t prev_end_ns = 0;
  const auto period_ns = static_cast<std::int64_t>(std::llround(1e9 / cfg_.rate_hz));
  auto to_ns = [](const timespec& t) { return static_cast<std::int64_t>(t.tv_sec) * 1000000000LL + t.tv_nsec; };
  auto from_ns = [](std::int64_t ns) {
    timespec t;
    t.tv_sec = static_cast<time_t>(ns / 1000000000LL);
    t.tv_nsec = static_cast<long>(ns % 1000000000LL);
    return t;
  };
  // The deadline grid: t0 + k period. After a stall the loop never bursts to catch up (a burst
  // replays the device's states back to back and turns one stall into several late steps that
  // tripped the watchdog); it goes on at the next grid point, and the grid points that had no
  // step are counted (EngineStats::periods_skipped). A wake-up more than a period late is one
  // missed deadline; so is a step that ran past the next deadline (its own overrun): the step
  // after it is measured against that deadline. The watchdog (consecutive missed deadlines)
  // therefore trips when the loop cannot keep its rate, not after one stall that has passed.
  timespec now0;
  clock_gettime(CLOCK_MONOTONIC, &now0);
  std::int64_t due_ns = to_ns(now0) + period_ns;  // the deadline this step is judged by
  std::int64_t wake_ns = due_ns;                   // the grid point the loop sleeps to (>= due)
  while (!stop_.load(std::memory_order_acquire)) {
    const timespec next = from_ns(wake_ns);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
    }
    timespec woke;
    clock_gettime(CLOCK_MONOTONIC, &woke);
    const std::int64_t woke_ns = to_ns(woke);
    double late = 1e-9 * static_cast<double>(woke_ns - due_ns);
    if (wake_ns > due_ns && late <= dt_s_) late = dt_s_ * (1 + 1e-9);  // the previous step overran
    stats_.jitter.record(late);
    const std::uint64_t trips0 = stats_.watchdog_trips;
    if (!step(late, true)) {
      finished_.store(true, std::memory_order_release);
      break;
    }
    if (late > monitor_from_s) {
      // Into the monitor's preallocated ring: no allocation, lock or wait (wake_monitor.h).
      WakeEvent ev;
      ev.deadline_ns = due_ns;
      ev.late_ns = woke_ns - due_ns;
      ev.prev_end_ns = prev_end_ns;
      ev.missed = late > dt_s_;
      ev.tripped = stats_.watchdog_trips != trips0;
      monitor_->push(ev);
    }
    timespec end;
    clock_gettime(CLOCK_MONOTONIC, &end);
    prev_end_ns = to_ns(end);
    // The next deadline: the first grid point after the wake-up (the points a late wake-up
    // passed are its own miss); the loop sleeps to the first grid point after the step's end.
    const std::int64_t passed_at_wake = woke_ns > due_ns ? (woke_ns - due_ns) / period_ns : 0;
    due_ns += (passed_at_wake + 1) * period_ns;
    wake_ns = due_ns;
    while (wake_ns <= prev_end_ns) wake_ns += period_ns;  // the step overran: judged at due_ns
    stats_.periods_skipped += static_cast<std::uint64_t>(passed_at_wake + (wake_ns - due_ns) / period_ns);
  }
  device_->write_force(guard_.zero());  // leave the device at zero force
  running_.store(false, std::memory_order_release);
}

EngineStats Engine::stats() const {
  if (running()) {
    EngineStats s;
    s.steps = steps_published_.load(std::memory_order_relaxed);
    return s;
  }
  EngineStats s = stats_;
  s.guard_clamped = guard_.clamped_steps();
  s.guard_rate_limited = guard_.rate_limited_steps();
  s.log_dropped = log_ ? log_->dropped() : 0;
  return s;
}

std::string Engine::header_json(const std::string& tooth_description_json) const {
  nlohmann::json j;
  j["format"] = "dentar-session";
  j["rate_hz"] = cfg_.rate_hz;
  j["model"] = cfg_.model;
  const auto& sp = cfg_.model_params.seed;
  j["seed"] = {{"density_scale_N", sp.density_scale_N},
               {"c1_N", sp.c1_N},
               {"c2_N_s_per_m", sp.c2_N_s_per_m},
               {"history", sp.history}};
  const auto& pp = cfg_.model_params.proxy;
  j["proxy"] = {{"stiffness_N_per_m", pp.stiffness_N_per_m},
                {"damping_N_s_per_m", pp.damping_N_s_per_m},
                {"max_cut_depth_m", pp.max_cut_depth_m}};
  j["cut"] = {{"base_rate_per_s", cfg_.cut.base_rate_per_s},
              {"reference_force_N", cfg_.cut.reference_force_N},
              {"max_effective_force_N", cfg_.cut.max_effective_force_N},
              {"min_force_N", cfg_.cut.min_force_N}};
  // Written only when on, so sessions cut without it keep their header bytes.
  if (cfg_.cut.sample_jitter) j["cut"]["sample_jitter"] = true;
  // Session 22, likewise written only when on.
  if (cfg_.cut.overlap) j["cut"]["overlap"] = true;
  if (pp.shape_constraint) j["proxy"]["shape_constraint"] = true;
  const auto& b = bur_->params;
  j["bur"] = {{"id", cfg_.bur_id},
              {"shape", std::string(volume::bur_shape_name(b.shape))},
              {"radius_m", b.radius_m},
              {"length_m", b.length_m},
              {"tip_radius_m", b.tip_radius_m},
              {"samples", bur_->size()}};
  j["T_tooth_dev"] = iso_json(cfg_.T_tooth_dev);
  j["T_sty_tip"] = iso_json(cfg_.T_sty_tip);
  j["watchdog_missed_deadlines"] = cfg_.watchdog_missed_deadlines;
  j["watchdog_rearm_steps"] = cfg_.watchdog_rearm_steps;
  j["max_force_rate_N_per_s"] = cfg_.max_force_rate_N_per_s;
  const auto& L = device_->limits();
  j["device"] = {{"name", device_->name()},
                 {"max_force_N", L.max_force_N},
                 {"max_stiffness_N_per_m", L.max_stiffness_N_per_m},
                 {"workspace_min_m", {L.workspace_min_m.x(), L.workspace_min_m.y(), L.workspace_min_m.z()}},
                 {"workspace_max_m", {L.workspace_max_m.x(), L.workspace_max_m.y(), L.workspace_max_m.z()}}};
  j["tooth"] = nlohmann::json::parse(tooth_description_json, nullptr, false);
  if (cfg_.training) {
    // Enough to rebuild the mode on replay: the student's poses drive it deterministically.
    const TrainingParams& t = cfg_.training->params();
    const GuidanceParams& g = t.guidance;
    const ExpertTrack& tr = cfg_.training->track();
    char eh[17];
    std::snprintf(eh, sizeof eh, "%016llx", static_cast<unsigned long long>(tr.content_hash()));
    j["training"] = {
        {"mode", static_cast<int>(t.mode)},
        {"mode_name", training_mode_name(t.mode)},
        {"guidance",
         {{"k_N_per_m", g.k_N_per_m}, {"eps1_m", g.eps1_m}, {"eps2_m", g.eps2_m},
          {"damping_N_s_per_m", g.damping_N_s_per_m}, {"across_path_only", g.across_path_only},
          {"quadratic_core", g.quadratic_core}, {"as_needed", g.as_needed}, {"as_needed_gain", g.as_needed_gain},
          {"as_needed_min", g.as_needed_min}, {"as_needed_tau_s", g.as_needed_tau_s}, {"fade", g.fade},
          {"repetition", g.repetition}, {"amplify", g.amplify}}},
        {"tolerance",
         {{"eps_m", t.tolerance.eps_m},
          {"theta_rad", {t.tolerance.theta_rad[0], t.tolerance.theta_rad[1], t.tolerance.theta_rad[2]}}}},
        {"conditional_replay", t.conditional_replay},
        {"speed", t.speed},
        {"ramp_s", t.ramp_s},
        {"expert", {{"file", t.expert_file}, {"hash", eh}, {"T_tooth_dev", iso_json(tr.T_tooth_dev())},
                    {"T_sty_tip", iso_json(tr.T_sty_tip())}}}};
  }
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx",
                static_cast<unsigned long long>(volume_->content_hash()));
  j["volume_hash_start"] = hash;  // hex: JSON numbers lose 64-bit precision
  return j.dump();
}

}  // namespace dentar::haptics
