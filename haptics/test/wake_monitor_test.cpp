// The engine's late wake-ups attributed (issue 28): the counter parsers on real and malformed
// text, the attribution rule on synthetic samples, and the monitor's ring.
#include "dentar/haptics/wake_monitor.h"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <vector>

#include "alloc_counter.h"  // counts this thread's heap allocations

namespace dentar::haptics {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

TEST(WakeCounters, TaskSchedstatReadsThreeNumbers) {
  auto r = parse_task_schedstat("70354 52057 2\n");
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->run_ns, 70354u);
  EXPECT_EQ(r->wait_ns, 52057u);
  EXPECT_EQ(r->slices, 2u);
  auto big = parse_task_schedstat("18446744073709551615 0 0");
  ASSERT_TRUE(big.ok());
  EXPECT_EQ(big->run_ns, 18446744073709551615ull);
}

TEST(WakeCounters, TaskSchedstatRefusesMalformedText) {
  for (const char* bad : {"", "\n", "1 2", "1 x 3", "-1 2 3", "1 2 3x", "18446744073709551616 0 0"}) {
    auto r = parse_task_schedstat(bad);
    ASSERT_FALSE(r.ok()) << "'" << bad << "'";
    EXPECT_NE(r.error().find("run_ns wait_ns timeslices"), std::string::npos) << r.error();
  }
}

constexpr const char* kProcStat =
    "cpu  8305085 5723030 1269087 1604188 69673 0 16997 17949 0 0\n"
    "cpu0 4102427 2893844 638887 825075 29355 0 5310 8995 0 0\n"
    "cpu1 4202657 2829185 630199 779113 40318 3 11687 8953 0 0\n"
    "cpu10 1 2 3 4 5 6 7 8 9 10\n"
    "intr 123 0 9 0\n"
    "ctxt 456\n";

TEST(WakeCounters, ProcStatPicksTheCpusOwnLine) {
  auto c1 = parse_proc_stat_cpu(kProcStat, 1);
  ASSERT_TRUE(c1.ok()) << c1.error();
  EXPECT_EQ(c1->user, 4202657u);
  EXPECT_EQ(c1->idle, 779113u);
  EXPECT_EQ(c1->irq, 3u);
  EXPECT_EQ(c1->softirq, 11687u);
  EXPECT_EQ(c1->steal, 8953u);
  auto c10 = parse_proc_stat_cpu(kProcStat, 10);  // "cpu1" is not "cpu10", nor the reverse
  ASSERT_TRUE(c10.ok());
  EXPECT_EQ(c10->steal, 8u);
  auto c0 = parse_proc_stat_cpu(kProcStat, 0);
  ASSERT_TRUE(c0.ok());
  EXPECT_EQ(c0->steal, 8995u);
}

TEST(WakeCounters, ProcStatRefusesMalformedLines) {
  auto none = parse_proc_stat_cpu(kProcStat, 3);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("no line for cpu3"), std::string::npos) << none.error();
  auto short_line = parse_proc_stat_cpu("cpu1 1 2 3 4 5 6 7\n", 1);  // no steal column
  ASSERT_FALSE(short_line.ok());
  EXPECT_NE(short_line.error().find("steal"), std::string::npos) << short_line.error();
  auto junk = parse_proc_stat_cpu("cpu1 1 2 3 four 5 6 7 8\n", 1);
  ASSERT_FALSE(junk.ok());
  EXPECT_NE(junk.error().find("cpu1"), std::string::npos) << junk.error();
  EXPECT_FALSE(parse_proc_stat_cpu("", 0).ok());
}

TEST(WakeCounters, ProcSchedstatReadsRunTimeAndWait) {
  const char* text =
      "version 15\ntimestamp 4295112305\n"
      "cpu0 0 0 0 0 0 0 1111 2222 3333\ndomain0 3 1 2 3\n"
      "cpu1 0 0 10 2 5 4 987654321 123456 789\n";
  auto r = parse_proc_schedstat_cpu(text, 1);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->run_ns, 987654321u);
  EXPECT_EQ(r->wait_ns, 123456u);
  EXPECT_EQ(r->slices, 789u);
  auto old = parse_proc_schedstat_cpu("cpu1 1 2 3 4 5 6\n", 1);
  ASSERT_FALSE(old.ok());
  EXPECT_NE(old.error().find("9 numbers"), std::string::npos) << old.error();
}

TEST(WakeCounters, TaskStatProcessorCountsFieldsAfterTheCommand) {
  // A real line (cat on CPU 1), and the same with a command name holding spaces and ')'.
  const std::string tail =
      " R 16541 16541 6224 0 -1 4194304 104 0 0 0 0 0 0 0 20 0 1 0 8543720 3133440 388 18446744073709551615 "
      "94290676166656 94290676186537 140722707461520 0 0 0 0 0 0 0 0 0 17 1 0 0 0 0 0 94290676202544 "
      "94290676204160 94290872889344 140722707462798 140722707462818 140722707462818 140722707464171 0\n";
  auto r = parse_task_stat_processor("16545 (cat)" + tail);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(*r, 1);
  auto odd = parse_task_stat_processor("16545 (a b) (c) 0)" + tail);
  ASSERT_TRUE(odd.ok()) << odd.error();
  EXPECT_EQ(*odd, 1);
  auto cut = parse_task_stat_processor("16545 (cat) R 1 2 3");
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.error().find("field 39"), std::string::npos) << cut.error();
  EXPECT_FALSE(parse_task_stat_processor("16545 cat R 1 2 3").ok());
  std::string bad = "1 (x)" + tail;
  const std::size_t at = bad.find(" 17 1 ");
  ASSERT_NE(at, std::string::npos);
  bad[at + 4] = 'z';  // field 39 is not a number
  EXPECT_FALSE(parse_task_stat_processor(bad).ok());
}

// Real input: this machine's own files parse, and name this thread's CPU.
TEST(WakeCounters, ThisMachinesFilesParse) {
  const int tid = static_cast<int>(::gettid());
  auto ss = parse_task_schedstat(slurp("/proc/self/task/" + std::to_string(tid) + "/schedstat"));
  ASSERT_TRUE(ss.ok()) << ss.error();
  EXPECT_GE(ss->slices, 1u);  // run_ns may still be 0 in a fresh process (updated at scheduler events)
  auto st = parse_task_stat_processor(slurp("/proc/self/task/" + std::to_string(tid) + "/stat"));
  ASSERT_TRUE(st.ok()) << st.error();
  EXPECT_GE(*st, 0);
  EXPECT_LT(*st, CPU_SETSIZE);
  auto c = parse_proc_stat_cpu(slurp("/proc/stat"), 0);
  ASSERT_TRUE(c.ok()) << c.error();
  EXPECT_GT(c->user + c->system + c->idle, 0u);
}

WakeSample late(double ms) {
  WakeSample s;
  s.late_s = ms * 1e-3;
  s.window_s = s.late_s + 2e-3;
  return s;
}

TEST(WakeAttribution, EachRuleOnSyntheticSamples) {
  WakeSample s = late(3);
  s.overran = true;  // no sleep: the previous step ran past this deadline
  s.engine_wait_s = 3e-3;
  s.ours_run_s = 3e-3;
  EXPECT_EQ(attribute_wake(s), WakeCause::kStep);

  s = late(3);
  s.steal_s = 0.01;  // one 10 ms tick of steal in the window
  s.engine_wait_s = 3e-3;
  s.ours_run_s = 3e-3;
  EXPECT_EQ(attribute_wake(s), WakeCause::kHostSteal);

  s = late(4);
  s.engine_wait_s = 3.9e-3;  // queued behind our mesher
  s.ours_run_s = 3.8e-3;
  s.cpu_others_run_s = 3.8e-3;
  EXPECT_EQ(attribute_wake(s), WakeCause::kOurThread);

  s.ours_run_s = 0.2e-3;  // behind someone else (who, unseen without /proc/schedstat)
  EXPECT_EQ(attribute_wake(s), WakeCause::kOtherTask);
  s.others_known = true;  // seen: others ran 3.8 ms
  EXPECT_EQ(attribute_wake(s), WakeCause::kOtherTask);

  s.irq_s = 0.01;
  EXPECT_EQ(attribute_wake(s), WakeCause::kIrq);

  s.irq_s = 0;  // queued, every task's run time seen and nobody ran: the virtual CPU was off
  s.cpu_others_run_s = 0.2e-3;
  EXPECT_EQ(attribute_wake(s), WakeCause::kHostSteal);
  s.others_known = false;  // without /proc/schedstat that cannot be told from another process
  EXPECT_EQ(attribute_wake(s), WakeCause::kOtherTask);

  s = late(5);  // not queued: the timer itself fired late
  s.engine_wait_s = 20e-6;
  EXPECT_EQ(attribute_wake(s), WakeCause::kHostSteal);
  s.irq_s = 0.01;
  EXPECT_EQ(attribute_wake(s), WakeCause::kIrq);

  // Half the lateness is the bar: 1.4 ms of a 3 ms wait is not enough for "our thread".
  s = late(3);
  s.engine_wait_s = 3e-3;
  s.ours_run_s = 1.4e-3;
  s.cpu_others_run_s = 1.6e-3;
  s.others_known = true;
  EXPECT_EQ(attribute_wake(s), WakeCause::kOtherTask);

  EXPECT_EQ(attribute_wake(WakeSample{}), WakeCause::kUnexplained);
  for (int c = 0; c < static_cast<int>(WakeCause::kCount); ++c)
    EXPECT_STRNE(wake_cause_name(static_cast<WakeCause>(c)), "?");
}

std::int64_t now_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

TEST(WakeMonitor, PushNeverAllocatesAndCountsWhatTheRingCannotHold) {
  WakeMonitor::Options o;
  o.ring = 4;
  WakeMonitor m(o);  // not started: nothing drains the ring
  const long before = dentar::test::this_thread_allocations();
  for (int i = 0; i < 6; ++i) m.push(WakeEvent{i * 1000000LL, 300000, 0, 0, 0});
  EXPECT_EQ(dentar::test::this_thread_allocations() - before, 0);
  EXPECT_EQ(m.stats().dropped, 2u);
}

TEST(WakeMonitor, OverrunIsTheStepAndItsCatchUpKeepsTheCause) {
  cpu_set_t set;
  ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof set, &set), 0);
  int cpu = 0;
  while (!CPU_ISSET(cpu, &set)) ++cpu;
  WakeMonitor m;
  ASSERT_TRUE(m.start(static_cast<int>(::gettid()), cpu).ok());
  EXPECT_FALSE(m.start(static_cast<int>(::gettid()), cpu).ok());  // already running
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  // A step that ran 2.5 ms past its successor's deadline, then two catch-up steps (no
  // sleep), the third tripping the watchdog: all the step's own cost.
  const std::int64_t d = now_ns() - 4000000;
  m.push(WakeEvent{d, 2500000, d + 2400000, 1, 0});
  m.push(WakeEvent{d + 1000000, 1600000, d + 2600000, 1, 0});
  m.push(WakeEvent{d + 2000000, 700000, d + 2700000, 0, 1});
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  m.stop();
  const WakeStats s = m.stats();
  ASSERT_TRUE(s.available) << s.note;
  EXPECT_GT(s.samples, 0u);  // few under load: the monitor is not real time
  EXPECT_EQ(s.late, 3u);
  const int step = static_cast<int>(WakeCause::kStep);
  EXPECT_EQ(s.late_by[step], 3u);
  EXPECT_EQ(s.missed_by[step], 2u);
  EXPECT_EQ(s.trips_by[step], 1u);
  ASSERT_EQ(s.worst.size(), 3u);
  EXPECT_NEAR(s.worst[0].s.late_s, 2.5e-3, 1e-9);  // worst first
  EXPECT_FALSE(s.worst[0].s.cascade);
  EXPECT_TRUE(s.worst[1].s.cascade);
  // The summary block names every cause.
  const auto j = nlohmann::json::parse(wake_stats_json(s, 2e-4));
  EXPECT_EQ(j["missed_by"]["step"], 2);
  EXPECT_EQ(j["trips_by"]["host"], 0);
  EXPECT_EQ(j["worst"].size(), 3u);
  EXPECT_EQ(j["worst"][0]["cause"], "step");
}

// The tids of this process's threads.
std::vector<int> our_tids() {
  std::vector<int> t;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/task")) t.push_back(std::stoi(e.path().filename()));
  return t;
}

// A thread's timeslices so far (/proc/self/task/<tid>/schedstat, third number); -1: gone.
long long slices_of(int tid) {
  std::ifstream f("/proc/self/task/" + std::to_string(tid) + "/schedstat");
  long long run = 0, wait = 0, slices = -1;
  f >> run >> wait >> slices;
  return f ? slices : -1;
}

// The worst late wake-ups name the thread of ours that ran longest on the engine CPU.
// Session 22: the late wake-up's window is one in which wm-busy is known to have run (its own
// CPU clock advanced 10 ms inside it) and the monitor is known to have sampled before it (its
// thread went to sleep and woke again). It was a fixed 20 ms with sleeps of 100 ms around it:
// under `stress -c 2` (wm-busy sharing its CPU with a stress worker, the monitor not yet
// running) 1 run in 2 found no run time of wm-busy inside the window and named no thread.
TEST(WakeMonitor, NamesOurThreadOnTheEngineCpu) {
  cpu_set_t set;
  ASSERT_EQ(pthread_getaffinity_np(pthread_self(), sizeof set, &set), 0);
  int cpu = 0;
  while (!CPU_ISSET(cpu, &set)) ++cpu;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  std::atomic<bool> go{true};
  std::atomic<int> busy_tid{-1};
  std::thread busy([&] {
    pthread_setname_np(pthread_self(), "wm-busy");
    pthread_setaffinity_np(pthread_self(), sizeof one, &one);
    busy_tid.store(static_cast<int>(::gettid()));
    while (go.load()) {
    }
  });
  while (busy_tid.load() < 0) std::this_thread::yield();
  clockid_t busy_clock;
  ASSERT_EQ(pthread_getcpuclockid(busy.native_handle(), &busy_clock), 0);
  const auto busy_cpu_ns = [&] {
    timespec ts{};
    clock_gettime(busy_clock, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
  };
  // Watch this (sleeping) thread as if it were the engine on that CPU.
  const std::vector<int> before = our_tids();
  WakeMonitor m;
  ASSERT_TRUE(m.start(static_cast<int>(::gettid()), cpu).ok());
  int monitor_tid = -1;
  for (const int t : our_tids())
    if (std::find(before.begin(), before.end(), t) == before.end()) monitor_tid = t;
  ASSERT_GE(monitor_tid, 0);
  // Its first sample is taken before it first sleeps: two more timeslices after the first.
  const auto t_wait = std::chrono::steady_clock::now();
  while (slices_of(monitor_tid) < 3 && std::chrono::steady_clock::now() - t_wait < std::chrono::seconds(20))
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_GE(slices_of(monitor_tid), 3) << "the monitor thread did not run in 20 s";
  // The late wake-up: from here until wm-busy has run 10 ms on the engine CPU.
  const std::int64_t d = now_ns();
  const std::int64_t c0 = busy_cpu_ns();
  while (busy_cpu_ns() - c0 < 10000000 && now_ns() - d < 20000000000LL)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_GE(busy_cpu_ns() - c0, 10000000) << "wm-busy did not run 10 ms in 20 s";
  m.push(WakeEvent{d, now_ns() - d, d - 500000, 1, 0});
  m.stop();  // its last sample, after the push, closes the window
  go.store(false);
  busy.join();
  const WakeStats s = m.stats();
  ASSERT_EQ(s.worst.size(), 1u);
  EXPECT_EQ(s.worst[0].thread_tid, busy_tid.load());
  EXPECT_EQ(s.worst[0].thread_name, "wm-busy");
  EXPECT_GT(s.worst[0].s.ours_run_s, 0.0);
}

TEST(WakeMonitor, RefusesAnUnpinnedEngineAndAMissingThread) {
  WakeMonitor m;
  auto s = m.start(static_cast<int>(::gettid()), -1);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("not pinned"), std::string::npos) << s.error();
  WakeMonitor m2;
  auto gone = m2.start(999999999, 0);
  ASSERT_FALSE(gone.ok());
  EXPECT_NE(gone.error().find("/proc/self/task/999999999/schedstat"), std::string::npos) << gone.error();
}

}  // namespace
}  // namespace dentar::haptics
