// The shared 1 kHz haptic engine: reads the device, computes the force in
// the tooth frame, cuts while the pedal is down, guards and sends the force,
// publishes a snapshot for graphics and records every step.
//
// Two ways to run the same step():
//  - start(): a dedicated thread paced by absolute deadlines
//    (clock_nanosleep TIMER_ABSTIME), SCHED_FIFO when the system grants it;
//  - run_steps(n): inline, in simulated time, as fast as the CPU allows
//    (tests, offline replay). Deterministic.
// The step never allocates, locks, does I/O, or waits for graphics/camera.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "dentar/haptics/device.h"
#include "dentar/haptics/force_guard.h"
#include "dentar/haptics/force_model.h"
#include "dentar/haptics/guidance.h"
#include "dentar/haptics/pose_history.h"
#include "dentar/haptics/seqlock.h"
#include "dentar/haptics/session_log.h"
#include "dentar/haptics/timing.h"
#include "dentar/haptics/wake_monitor.h"
#include "dentar/volume/cutter.h"

namespace dentar::haptics {

struct EngineConfig {
  double rate_hz = 1000.0;
  std::string model = "proxy";  // "seed" or "proxy"
  ForceModelParams model_params;
  volume::CutParams cut;
  Eigen::Isometry3d T_tooth_dev = Eigen::Isometry3d::Identity();  // static, station calibration
  Eigen::Isometry3d T_sty_tip = Eigen::Isometry3d::Identity();    // static, pivot calibration
  std::uint8_t bur_id = 0;
  // Watchdog: zero force after this many consecutive missed deadlines (steps; after a stall the
  // real-time loop does not burst to catch up, so one stall is one miss and the watchdog trips
  // when the loop cannot keep its rate); force returns (ramped by the guard) after
  // `watchdog_rearm_steps` good steps.
  int watchdog_missed_deadlines = 3;
  int watchdog_rearm_steps = 50;
  double max_force_rate_N_per_s = 2000.0;  // spike limit for the guard
  bool try_realtime = true;                // ask for SCHED_FIFO
  int realtime_priority = 80;
  // Real-time thread only: pin the engine thread to this CPU (-1 = no pin),
  // and touch `prefault_stack_bytes` of its stack before the first step so
  // no page fault lands inside a step (with mlockall the pages stay).
  int cpu = -1;
  std::size_t prefault_stack_bytes = 256 * 1024;
  // Real-time thread pinned to `cpu` only: a monitor thread (normal priority, on the CPUs of
  // the caller of start()) reads the scheduler's counters and names the cause of each late
  // wake-up (wake_monitor.h); the engine thread only pushes {deadline, lateness} into a
  // preallocated ring. Results in EngineStats::wake.
  bool monitor_wakes = false;
  // A training mode (issue 27; not owned, must outlive the engine; the haptic thread calls
  // it every step): its forces go through the same guard and watchdog as contact forces.
  TrainingMode* training = nullptr;
  std::string validate() const;  // empty when valid, else names the field
};

// The session-22 cutter/proxy pairing, the same for every sample count: cut by
// overlap volume (volume::CutParams::overlap) at kOverlapBaseRatePerS, and
// constrain the proxy with the bur's shape (ProxyParams::shape_constraint).
inline void use_overlap_cut(EngineConfig& cfg) {
  cfg.cut.overlap = true;
  cfg.cut.base_rate_per_s = volume::kOverlapBaseRatePerS;
  cfg.model_params.proxy.shape_constraint = true;
}


// What graphics reads (lock-free). Plain data.
struct HapticSnapshot {
  std::uint64_t step = 0;        // index of the step that published this (0-based)
  std::uint64_t steps_done = 0;  // steps run so far, this one included (0: none yet)
  double time_s = 0;
  double T_tooth_tip_display[16] = {};  // column-major 4x4: where to draw the bur
  double T_dev_sty[16] = {};            // column-major 4x4: measured stylus
  double force_dev_N[3] = {0, 0, 0};    // sent to the device
  std::uint32_t contacts = 0;
  std::uint8_t pedal = 0, in_contact = 0, fault = 0, watchdog = 0;
  std::uint8_t pulp_exposed = 0;
  double pulp_exposed_at_s = 0;  // device time of the exposure (valid when pulp_exposed)
  double removed_mm3[8] = {};  // cumulative, per material label
  // Training mode (mode 0: none): where the expert's tool is, for the second handpiece.
  std::uint8_t mode = 0, expert_drilling = 0, expert_waiting = 0;
  double expert_time_s = 0;
  double T_tooth_expert_tip[16] = {};  // column-major 4x4
  double follow_error_m = 0;           // student tip to expert tip
};

struct EngineStats {
  std::uint64_t steps = 0;
  std::uint64_t missed_deadlines = 0;   // steps that started more than one period after their deadline
  std::uint64_t periods_skipped = 0;    // real-time mode: 1 ms grid points with no step (stalls, overruns)
  std::uint64_t watchdog_trips = 0;
  std::uint64_t device_faults = 0;
  std::uint64_t guard_clamped = 0, guard_rate_limited = 0;
  std::uint64_t log_dropped = 0;
  bool realtime_granted = false;  // SCHED_FIFO obtained (real-time mode only)
  bool cpu_pinned = false;        // the thread runs only on EngineConfig::cpu
  std::string realtime_note;      // why not, when not
  TimingHistogram compute;        // time inside step()
  TimingHistogram jitter;         // wake-up time minus deadline (real-time mode)
  WakeStats wake;                 // late wake-ups attributed (EngineConfig::monitor_wakes)
};

class Engine {
 public:
  // Validates the config; builds the force model and cutter. Nothing is
  // owned: device, volume, bur and log (nullable) must outlive the engine.
  static Result<std::unique_ptr<Engine>> create(const EngineConfig& cfg, HapticDevice& device,
                                                volume::VoxelVolume& volume,
                                                const volume::BurSamples& bur,
                                                SessionLogWriter* log = nullptr);
  ~Engine();  // stops the thread
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  // Real time. start() fails if already running.
  Status start();
  void stop();
  bool running() const { return running_.load(std::memory_order_acquire); }
  // While the thread runs: whether it got SCHED_FIFO and its CPU pin (known
  // once its first step ran; both false before). After stop(): see stats().
  bool realtime_granted_now() const { return rt_granted_.load(std::memory_order_acquire); }
  bool cpu_pinned_now() const { return cpu_pinned_.load(std::memory_order_acquire); }
  // True when the device source ended (replay) and the thread stopped itself.
  bool finished() const { return finished_.load(std::memory_order_acquire); }

  // Simulated time: runs up to n steps inline; returns how many ran (fewer
  // when a replayed source ends). Not while the thread runs. `late_s`
  // pretends each step woke that late (to test the deadline watchdog).
  std::uint64_t run_steps(std::uint64_t n, double late_s = 0.0);

  HapticSnapshot snapshot() const { return snapshot_.load(); }
  // The stylus poses of the last ~1 s, one per step (issue 24: the frame path draws the pose of
  // a frame's exposure, not the newest one). Lock-free for readers; the haptic thread writes it
  // without waiting. Times: CLOCK_MONOTONIC seconds (= steady_clock, ar::steady_now_s()) taken
  // when the step read the device, while the thread runs; the device's own time_s under
  // run_steps() (simulated time). A faulted step is stored invalid.
  const PoseHistory& pose_history() const { return pose_history_; }
  // Copy of the statistics. While the thread runs only `steps` is filled
  // (the rest belongs to the haptic thread); call after stop() for all.
  // Other threads may call it between start() and stop(), not concurrently
  // with them.
  EngineStats stats() const;
  const volume::Cutter& cutter() const { return cutter_; }
  const EngineConfig& config() const { return cfg_; }
  // Engine configuration as JSON: the session log header (docs/formats.md).
  std::string header_json(const std::string& tooth_description_json) const;

 private:
  Engine(const EngineConfig& cfg, HapticDevice& device, volume::VoxelVolume& volume,
         const volume::BurSamples& bur, SessionLogWriter* log,
         std::unique_ptr<ForceModel> model);
  // One haptic step; false when the device source has ended. `in_thread`: the real-time thread
  // (the pose history is stamped with CLOCK_MONOTONIC, else with the device's time).
  bool step(double late_s, bool in_thread) noexcept;
  void thread_main();

  EngineConfig cfg_;
  HapticDevice* device_;
  volume::VoxelVolume* volume_;
  const volume::BurSamples* bur_;
  SessionLogWriter* log_;
  std::unique_ptr<ForceModel> model_;
  volume::Cutter cutter_;
  ForceGuard guard_;
  Ramp contact_gain_{0.25, 1.0};  // contact force fades out/in when a mode turns it off/on
  double dt_s_;

  // Haptic-thread state.
  std::uint64_t step_index_ = 0;
  int consecutive_missed_ = 0;
  int good_since_trip_ = 0;
  bool watchdog_tripped_ = false;
  bool pulp_exposed_ = false;
  double pulp_exposed_at_s_ = 0;
  double removed_mm3_[8] = {};  // cumulative per material, for the snapshot
  EngineStats stats_;

  SeqLock<HapticSnapshot> snapshot_;
  PoseHistory pose_history_;
  std::atomic<std::uint64_t> steps_published_{0};
  std::atomic<bool> running_{false}, stop_{false}, finished_{false};
  std::atomic<bool> rt_granted_{false}, cpu_pinned_{false};
  std::atomic<int> tid_{-1};              // the engine thread's id, once it runs
  std::unique_ptr<WakeMonitor> monitor_;  // EngineConfig::monitor_wakes
  std::string monitor_note_;              // why it did not start (caller's thread)
  std::thread thread_;
};

// Whether this process may run a thread under SCHED_FIFO at `priority`: tried
// on a short-lived probe thread (the caller's scheduling is untouched). When
// not, `why` (if given) gets the system's reason. Used before placing other
// threads beside the engine: without FIFO they would share its core equally.
bool realtime_available(int priority, std::string* why = nullptr);

}  // namespace dentar::haptics
