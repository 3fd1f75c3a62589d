// Why the 1 kHz engine woke late (issue 28, goal 4): per late wake-up, the
// scheduler's own counters around it, read by a monitor thread that is not
// real time, and a rule that names the cause.
//
// What is read (Linux):
//  - /proc/self/task/<tid>/schedstat of the engine thread: time on the CPU,
//    time runnable but waiting in the run queue, timeslices (ns, ns, count);
//  - /proc/schedstat, the engine CPU's line: the run time of every task on
//    that CPU (ns), so "others ran on the engine CPU" = that minus the
//    engine's own;
//  - /proc/stat, the engine CPU's line: steal (the hypervisor ran something
//    else instead of this virtual CPU), irq and softirq, in USER_HZ ticks
//    (10 ms: coarse, summed over the run they are exact);
//  - /proc/self/task/*/stat field 39 (`processor`, the CPU a thread last ran
//    on) and each thread's schedstat run time: which of our own threads ran on
//    the engine CPU.
// The engine thread only copies {deadline, lateness, its previous step's end}
// into a preallocated ring (WakeEvent); it never reads a file.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "dentar/core/result.h"

namespace dentar::haptics {

// ---- Counter parsing (pure; tested on real and malformed text) ----

// /proc/<pid>/task/<tid>/schedstat: "run_ns wait_ns timeslices\n".
struct TaskSchedstat {
  std::uint64_t run_ns = 0;   // time on the CPU
  std::uint64_t wait_ns = 0;  // time runnable, waiting in a run queue
  std::uint64_t slices = 0;   // times it was given the CPU
};
Result<TaskSchedstat> parse_task_schedstat(std::string_view text);

// One CPU's line of /proc/stat ("cpuN user nice system idle iowait irq softirq steal ..."),
// in USER_HZ ticks. Fields after steal (guest, guest_nice) are ignored; a line
// with fewer than 8 numbers is an error (kernels before 2.6.11 had no steal).
struct CpuTicks {
  std::uint64_t user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0, steal = 0;
};
Result<CpuTicks> parse_proc_stat_cpu(std::string_view proc_stat, int cpu);

// /proc/schedstat, one CPU's line ("cpuN a b c d e f rq_cpu_time run_delay pcount"
// in versions 15-17): the run time of all tasks on that CPU and their summed
// run-queue wait, in ns.
struct CpuSchedstat {
  std::uint64_t run_ns = 0;
  std::uint64_t wait_ns = 0;
  std::uint64_t slices = 0;
};
Result<CpuSchedstat> parse_proc_schedstat_cpu(std::string_view proc_schedstat, int cpu);

// /proc/<pid>/task/<tid>/stat: field 39, the CPU the thread last ran on. The
// command name (field 2) may hold spaces and parentheses: fields are counted
// after its last ')'.
Result<int> parse_task_stat_processor(std::string_view text);

// ---- Attribution ----

enum class WakeCause : std::uint8_t {
  kStep = 0,      // the previous step ran past this deadline (its own cost): no sleep at all
  kHostSteal,     // the virtual CPU did not run: the timer fired late with the engine not
                  // queued behind anything, or steal covered the wait
  kOurThread,     // runnable but behind another thread of this process on the engine CPU
  kOtherTask,     // runnable but behind another process or a kernel thread on the engine CPU
  kIrq,           // interrupt / softirq time on the engine CPU covered it
  kUnexplained,   // none of the counters covers half of the lateness
  kCount
};
const char* wake_cause_name(WakeCause c);

// The counters' change from the last sample before a late wake-up's deadline
// to the first sample after it woke (the window), plus what the engine saw.
struct WakeSample {
  double late_s = 0;            // wake-up time minus deadline
  bool overran = false;         // the previous step ended after this deadline (no sleep)
  bool cascade = false;         // the previous step's wake-up was late too (catching up)
  double engine_wait_s = 0;     // engine thread: run-queue wait in the window
  double engine_run_s = 0;      // engine thread: time on the CPU in the window
  double cpu_others_run_s = 0;  // every other task on the engine CPU in the window
  bool others_known = false;    // cpu_others_run_s counts every task (/proc/schedstat), not only ours
  double ours_run_s = 0;        // of that, threads of this process (last seen on that CPU)
  double steal_s = 0;           // engine CPU, /proc/stat (tick resolution)
  double irq_s = 0;             // engine CPU, irq + softirq (tick resolution)
  double window_s = 0;          // the window's length
};

// The rule (docs/formats.md "engine.wake"): a late wake-up that only catches up
// after a late one (cascade and overran) keeps the cause of the first one of its
// burst (the monitor does that); otherwise
//  1. overran: the step's own cost;
//  2. steal >= half the lateness: host;
//  3. the engine waited in the run queue for >= half the lateness: behind something on its
//     CPU: our thread when our threads' run time there covers half the wait, irq when irq
//     time does, else another task; with /proc/schedstat (others_known) a wait that no
//     task's run time covers is the host (the run queue's clock ran while nothing ran);
//  4. it did not wait (the timer itself fired late): irq when irq time covers half, else
//     host (in a guest nothing but an interrupt-disabled section or a stopped virtual CPU
//     delays a high-resolution timer by milliseconds).
WakeCause attribute_wake(const WakeSample& s);

// ---- The monitor ----

// Written by the engine thread per late wake-up (trivially copyable).
struct WakeEvent {
  std::int64_t deadline_ns = 0;  // CLOCK_MONOTONIC
  std::int64_t late_ns = 0;
  std::int64_t prev_end_ns = 0;  // when the previous step ended
  std::uint8_t missed = 0;       // counted as a missed deadline (later than one period)
  std::uint8_t tripped = 0;      // this step tripped the watchdog
};

struct WakeStats {
  bool available = false;      // the counters could be read
  std::string note;            // why not, or what was read
  int tid = -1, cpu = -1;      // the engine thread and its CPU (to match a perf/ftrace record)
  double window_s = 0;         // monitored time
  double cpu_steal_ms = 0;     // steal on the engine CPU over the run (/proc/stat)
  double cpu_irq_ms = 0;       // irq + softirq on the engine CPU over the run
  double cpu_others_run_ms = 0;  // other tasks' run time on the engine CPU over the run
  double engine_wait_ms = 0;   // the engine thread's run-queue wait over the run
  std::uint64_t samples = 0;   // counter samples taken
  std::uint64_t late = 0;      // late wake-ups examined (> threshold)
  std::uint64_t dropped = 0;   // late wake-ups the ring could not hold
  std::uint64_t late_by[static_cast<int>(WakeCause::kCount)] = {};
  std::uint64_t missed_by[static_cast<int>(WakeCause::kCount)] = {};
  std::uint64_t trips_by[static_cast<int>(WakeCause::kCount)] = {};
  double late_ms_by[static_cast<int>(WakeCause::kCount)] = {};
  // The worst late wake-ups (up to 8, by lateness), for the summary.
  struct Worst {
    double at_s = 0;  // seconds since the monitor started
    WakeSample s;
    WakeCause cause = WakeCause::kUnexplained;
    bool missed = false, tripped = false;
    // Of our threads on the engine CPU, the one that ran longest in the window (-1: none).
    int thread_tid = -1;
    std::string thread_name;  // its /proc/self/task/<tid>/comm
  };
  std::vector<Worst> worst;
};

// The stats as a JSON object (the `engine.wake` block of `dentar live --summary`,
// docs/formats.md): times in ms, counts per cause by wake_cause_name().
std::string wake_stats_json(const WakeStats& s, double late_threshold_s);

// Samples the counters every `period_s` on its own thread (normal priority,
// on the CPUs it was started on) and attributes each late wake-up the engine
// pushes. One producer (the engine thread: push() never allocates, locks or
// waits), one consumer (the monitor's own thread).
class WakeMonitor {
 public:
  struct Options {
    double period_s = 0.001;
    double late_threshold_s = 0.0002;  // wake-ups later than this are examined
    std::size_t ring = 4096;           // power of two
  };
  WakeMonitor();
  explicit WakeMonitor(const Options& o);
  ~WakeMonitor();
  WakeMonitor(const WakeMonitor&) = delete;
  WakeMonitor& operator=(const WakeMonitor&) = delete;

  // Starts the monitor thread watching thread `tid` on CPU `cpu`. Fails (with
  // the file that could not be read) when the counters are not there.
  Status start(int tid, int cpu);
  void stop();  // joins; then stats() is complete
  // Engine thread: a late wake-up (allocation-, lock- and wait-free).
  void push(const WakeEvent& e) noexcept;
  double late_threshold_s() const { return opt_.late_threshold_s; }
  WakeStats stats() const;  // after stop()

 private:
  struct Impl;
  Options opt_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dentar::haptics
