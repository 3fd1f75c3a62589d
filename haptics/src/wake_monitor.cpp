#include "dentar/haptics/wake_monitor.h"

#include <dirent.h>
#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <deque>
#include <map>

#include <nlohmann/json.hpp>

#include "spsc_ring.h"

namespace dentar::haptics {
namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Reads unsigned decimal numbers separated by blanks from `s` into out[0..n); returns how
// many were read before the end or the first token that is not a number (-1 then).
int read_numbers(std::string_view s, std::uint64_t* out, int n, bool* bad_token) {
  int k = 0;
  std::size_t i = 0;
  *bad_token = false;
  while (k < n) {
    while (i < s.size() && is_space(s[i])) ++i;
    if (i >= s.size()) break;
    std::size_t j = i;
    while (j < s.size() && !is_space(s[j])) ++j;
    std::uint64_t v = 0;
    const auto [p, ec] = std::from_chars(s.data() + i, s.data() + j, v);
    if (ec != std::errc() || p != s.data() + j) {
      *bad_token = true;
      break;
    }
    out[k++] = v;
    i = j;
  }
  return k;
}

// The line of `text` whose first word is exactly `name` (without it), or empty.
std::optional<std::string_view> line_named(std::string_view text, std::string_view name) {
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    if (line.size() > name.size() && line.substr(0, name.size()) == name && is_space(line[name.size()]))
      return line.substr(name.size());
    pos = end + 1;
  }
  return std::nullopt;
}

std::string quote(std::string_view s) {
  std::string q(s.substr(0, 60));
  for (char& c : q)
    if (c == '\n') c = ' ';
  return "\"" + q + (s.size() > 60 ? "...\"" : "\"");
}

std::int64_t mono_ns() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

// A /proc file kept open and re-read from its start (procfs regenerates it).
class ProcFile {
 public:
  ProcFile() = default;
  explicit ProcFile(const std::string& path) : path_(path), fd_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {}
  ~ProcFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  ProcFile(ProcFile&& o) noexcept : path_(std::move(o.path_)), fd_(o.fd_) { o.fd_ = -1; }
  ProcFile& operator=(ProcFile&& o) noexcept {
    std::swap(path_, o.path_);
    std::swap(fd_, o.fd_);
    return *this;
  }
  bool open() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  // The whole file into buf (grown as needed); false when it cannot be read.
  bool read(std::string& buf) const {
    if (fd_ < 0) return false;
    if (buf.size() < 4096) buf.resize(4096);
    for (;;) {
      const ssize_t n = ::pread(fd_, buf.data(), buf.size(), 0);
      if (n < 0) return false;
      if (static_cast<std::size_t>(n) < buf.size()) {
        len_ = static_cast<std::size_t>(n);
        return true;
      }
      buf.resize(buf.size() * 2);
    }
  }
  std::size_t len() const { return len_; }

 private:
  std::string path_;
  int fd_ = -1;
  mutable std::size_t len_ = 0;
};

}  // namespace

Result<TaskSchedstat> parse_task_schedstat(std::string_view text) {
  std::uint64_t v[3];
  bool bad = false;
  const int n = read_numbers(text, v, 3, &bad);
  if (bad || n != 3)
    return Error{"schedstat: expected 3 numbers \"run_ns wait_ns timeslices\", got " + quote(text)};
  return TaskSchedstat{v[0], v[1], v[2]};
}

Result<CpuTicks> parse_proc_stat_cpu(std::string_view proc_stat, int cpu) {
  const std::string name = "cpu" + std::to_string(cpu);
  const auto line = line_named(proc_stat, name);
  if (!line) return Error{"/proc/stat: no line for " + name};
  std::uint64_t v[8];
  bool bad = false;
  const int n = read_numbers(*line, v, 8, &bad);
  if (bad || n < 8)
    return Error{"/proc/stat: line " + name + " needs 8 numbers (user nice system idle iowait irq softirq steal), got " +
                 quote(*line)};
  return CpuTicks{v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]};
}

Result<CpuSchedstat> parse_proc_schedstat_cpu(std::string_view proc_schedstat, int cpu) {
  const std::string name = "cpu" + std::to_string(cpu);
  const auto line = line_named(proc_schedstat, name);
  if (!line) return Error{"/proc/schedstat: no line for " + name};
  std::uint64_t v[9];
  bool bad = false;
  const int n = read_numbers(*line, v, 9, &bad);
  if (bad || n < 9)
    return Error{"/proc/schedstat: line " + name + " needs 9 numbers (version 15-17), got " + quote(*line)};
  return CpuSchedstat{v[6], v[7], v[8]};
}

Result<int> parse_task_stat_processor(std::string_view text) {
  const std::size_t close = text.rfind(')');
  if (close == std::string_view::npos) return Error{"task stat: no \")\" after the command name in " + quote(text)};
  // Field 3 (state) follows the ')'; `processor` is field 39.
  std::string_view rest = text.substr(close + 1);
  int field = 2;
  std::size_t i = 0;
  while (true) {
    while (i < rest.size() && is_space(rest[i])) ++i;
    if (i >= rest.size()) break;
    std::size_t j = i;
    while (j < rest.size() && !is_space(rest[j])) ++j;
    ++field;
    if (field == 39) {
      int cpu = -1;
      const auto [p, ec] = std::from_chars(rest.data() + i, rest.data() + j, cpu);
      if (ec != std::errc() || p != rest.data() + j || cpu < 0)
        return Error{"task stat: field 39 (processor) is " + quote(rest.substr(i, j - i)) + ", not a CPU index"};
      return cpu;
    }
    i = j;
  }
  return Error{"task stat: " + std::to_string(field) + " fields, field 39 (processor) missing"};
}

const char* wake_cause_name(WakeCause c) {
  switch (c) {
    case WakeCause::kStep: return "step";
    case WakeCause::kHostSteal: return "host";
    case WakeCause::kOurThread: return "our_thread";
    case WakeCause::kOtherTask: return "other_task";
    case WakeCause::kIrq: return "irq";
    case WakeCause::kUnexplained: return "unexplained";
    case WakeCause::kCount: break;
  }
  return "?";
}

WakeCause attribute_wake(const WakeSample& s) {
  const double half = 0.5 * s.late_s;
  if (s.overran) return WakeCause::kStep;
  if (!(s.late_s > 0) || !(s.window_s > 0)) return WakeCause::kUnexplained;  // no counters around it
  if (s.steal_s >= half) return WakeCause::kHostSteal;
  if (s.engine_wait_s >= half) {
    const double w = 0.5 * s.engine_wait_s;
    if (s.ours_run_s >= w) return WakeCause::kOurThread;
    if (s.irq_s >= w) return WakeCause::kIrq;
    if (s.others_known && s.cpu_others_run_s < w) return WakeCause::kHostSteal;
    return WakeCause::kOtherTask;
  }
  if (s.irq_s >= half) return WakeCause::kIrq;
  return WakeCause::kHostSteal;
}

std::string wake_stats_json(const WakeStats& s, double late_threshold_s) {
  using nlohmann::json;
  auto by = [](const auto& arr) {
    json j = json::object();
    for (int c = 0; c < static_cast<int>(WakeCause::kCount); ++c) j[wake_cause_name(static_cast<WakeCause>(c))] = arr[c];
    return j;
  };
  json worst = json::array();
  for (const WakeStats::Worst& w : s.worst)
    worst.push_back({{"at_s", w.at_s}, {"late_ms", w.s.late_s * 1e3}, {"cause", wake_cause_name(w.cause)},
                     {"missed", w.missed}, {"tripped", w.tripped}, {"overran", w.s.overran},
                     {"cascade", w.s.cascade}, {"engine_wait_ms", w.s.engine_wait_s * 1e3},
                     {"engine_run_ms", w.s.engine_run_s * 1e3}, {"others_run_ms", w.s.cpu_others_run_s * 1e3},
                     {"ours_run_ms", w.s.ours_run_s * 1e3}, {"steal_ms", w.s.steal_s * 1e3},
                     {"irq_ms", w.s.irq_s * 1e3}, {"window_ms", w.s.window_s * 1e3},
                     {"thread_tid", w.thread_tid}, {"thread_name", w.thread_name}});
  json j = {{"available", s.available},
            {"note", s.note},
            {"engine_tid", s.tid},
            {"engine_cpu", s.cpu},
            {"window_s", s.window_s},
            {"samples", s.samples},
            {"late_threshold_us", late_threshold_s * 1e6},
            {"cpu_steal_ms", s.cpu_steal_ms},
            {"cpu_irq_ms", s.cpu_irq_ms},
            {"cpu_others_run_ms", s.cpu_others_run_ms},
            {"engine_wait_ms", s.engine_wait_ms},
            {"late", s.late},
            {"dropped", s.dropped},
            {"late_by", by(s.late_by)},
            {"late_ms_by", by(s.late_ms_by)},
            {"missed_by", by(s.missed_by)},
            {"trips_by", by(s.trips_by)},
            {"worst", worst}};
  return j.dump();
}

// ---- The monitor ----

struct WakeMonitor::Impl {
  explicit Impl(std::size_t ring) : events(ring) {}
  detail::SpscRing<WakeEvent> events;
  std::atomic<std::uint64_t> dropped{0};
  std::atomic<bool> stop{false};
  std::thread thread;
  WakeStats stats;
  int tid = -1, cpu = -1;

  static constexpr int kTop = 8;  // our threads tracked per sample (by tid)
  struct Sample {
    std::int64_t t_ns = 0;
    TaskSchedstat engine;
    std::uint64_t ours_run_ns = 0;  // summed over our other threads seen on the engine CPU
    int n_threads = 0;
    int thread_tid[kTop] = {};
    std::uint64_t thread_run_ns[kTop] = {};
    CpuTicks ticks;                 // refreshed every ~10 ms (tick resolution anyway)
    bool have_cpu_sched = false;
    CpuSchedstat cpu_sched;
  };
  std::deque<Sample> history;  // monitor thread only
  std::deque<WakeEvent> pending;
  std::map<int, ProcFile> ours;          // tid -> its schedstat, our threads last seen on the engine CPU
  std::map<int, std::uint64_t> ours_last;  // tid -> run_ns at the previous sample
  std::uint64_t ours_total_ns = 0;       // running sum of their run time
  ProcFile engine_schedstat, proc_stat, proc_schedstat;
  std::string buf;
  double tick_s = 0.01;
  std::int64_t prev_deadline_ns = 0;
  WakeCause burst_cause = WakeCause::kUnexplained;
  std::int64_t period_ns = 1000000;
  std::int64_t start_ns = 0;

  bool sample(Sample& s, bool with_ticks) {
    s.t_ns = mono_ns();
    if (!engine_schedstat.read(buf)) return false;
    auto e = parse_task_schedstat(std::string_view(buf.data(), engine_schedstat.len()));
    if (!e) return false;
    s.engine = *e;
    for (auto& [t, f] : ours) {
      if (!f.read(buf)) continue;  // the thread ended
      auto r = parse_task_schedstat(std::string_view(buf.data(), f.len()));
      if (!r) continue;
      std::uint64_t& last = ours_last[t];
      if (last != 0 && r->run_ns > last) ours_total_ns += r->run_ns - last;
      last = r->run_ns;
      if (s.n_threads < kTop) {
        s.thread_tid[s.n_threads] = t;
        s.thread_run_ns[s.n_threads] = r->run_ns;
        ++s.n_threads;
      }
    }
    s.ours_run_ns = ours_total_ns;
    if (with_ticks && proc_stat.read(buf)) {
      if (auto c = parse_proc_stat_cpu(std::string_view(buf.data(), proc_stat.len()), cpu); c) s.ticks = *c;
    } else if (!history.empty()) {
      s.ticks = history.back().ticks;
    }
    if (proc_schedstat.open() && proc_schedstat.read(buf)) {
      if (auto c = parse_proc_schedstat_cpu(std::string_view(buf.data(), proc_schedstat.len()), cpu); c) {
        s.cpu_sched = *c;
        s.have_cpu_sched = true;
      }
    }
    return true;
  }

  // Our threads (not the engine, not this one) whose `processor` is the engine CPU.
  void rescan_threads() {
    DIR* d = ::opendir("/proc/self/task");
    if (!d) return;
    const int self = static_cast<int>(::gettid());
    while (dirent* de = ::readdir(d)) {
      if (de->d_name[0] < '0' || de->d_name[0] > '9') continue;
      const int t = std::atoi(de->d_name);
      if (t == tid || t == self) continue;
      ProcFile st("/proc/self/task/" + std::to_string(t) + "/stat");
      if (!st.read(buf)) continue;
      auto p = parse_task_stat_processor(std::string_view(buf.data(), st.len()));
      if (!p || *p != cpu) continue;
      if (ours.count(t) == 0) ours.emplace(t, ProcFile("/proc/self/task/" + std::to_string(t) + "/schedstat"));
    }
    ::closedir(d);
  }

  static double d_ticks(std::uint64_t a, std::uint64_t b, double tick_s) {
    return b > a ? static_cast<double>(b - a) * tick_s : 0.0;
  }

  void attribute(const WakeEvent& e) {
    const std::int64_t wake = e.deadline_ns + e.late_ns;
    // A: the last sample at or before the deadline (else the oldest); B: the first at or after the wake.
    const Sample* a = &history.front();
    const Sample* b = &history.back();
    for (const Sample& s : history) {
      if (s.t_ns <= e.deadline_ns) a = &s;
      if (s.t_ns >= wake) {
        b = &s;
        break;
      }
    }
    WakeSample w;
    w.late_s = 1e-9 * static_cast<double>(e.late_ns);
    w.overran = e.prev_end_ns > e.deadline_ns;
    w.cascade = prev_deadline_ns != 0 && std::llabs(e.deadline_ns - period_ns - prev_deadline_ns) < period_ns / 4;
    w.window_s = 1e-9 * static_cast<double>(b->t_ns - a->t_ns);
    w.engine_wait_s = 1e-9 * static_cast<double>(b->engine.wait_ns - a->engine.wait_ns);
    w.engine_run_s = 1e-9 * static_cast<double>(b->engine.run_ns - a->engine.run_ns);
    w.ours_run_s = 1e-9 * static_cast<double>(b->ours_run_ns - a->ours_run_ns);
    if (a->have_cpu_sched && b->have_cpu_sched) {
      const double all = 1e-9 * static_cast<double>(b->cpu_sched.run_ns - a->cpu_sched.run_ns);
      w.cpu_others_run_s = std::max(0.0, all - w.engine_run_s);
      w.others_known = true;
    } else {
      w.cpu_others_run_s = w.ours_run_s;  // without /proc/schedstat only our own threads are seen
    }
    w.steal_s = d_ticks(a->ticks.steal, b->ticks.steal, tick_s);
    w.irq_s = d_ticks(a->ticks.irq + a->ticks.softirq, b->ticks.irq + b->ticks.softirq, tick_s);
    WakeCause c = attribute_wake(w);
    // Catching up (no sleep) right after a late wake-up: the burst's first cause. Late again
    // after having slept: a new stall with its own cause.
    if (w.cascade && w.overran) c = burst_cause;
    burst_cause = c;
    prev_deadline_ns = e.deadline_ns;
    const int ci = static_cast<int>(c);
    ++stats.late;
    ++stats.late_by[ci];
    stats.late_ms_by[ci] += w.late_s * 1e3;
    if (e.missed) ++stats.missed_by[ci];
    if (e.tripped) ++stats.trips_by[ci];
    WakeStats::Worst wr{1e-9 * static_cast<double>(e.deadline_ns - start_ns), w, c, e.missed != 0, e.tripped != 0, -1, {}};
    if (!stats.worst.empty() && stats.worst.size() >= 8 && w.late_s <= stats.worst.back().s.late_s) {
      // not among the worst: no need to name a thread
    } else {
      std::uint64_t best = 0;
      for (int i = 0; i < b->n_threads; ++i)
        for (int j = 0; j < a->n_threads; ++j)
          if (a->thread_tid[j] == b->thread_tid[i] && b->thread_run_ns[i] > a->thread_run_ns[j] &&
              b->thread_run_ns[i] - a->thread_run_ns[j] > best) {
            best = b->thread_run_ns[i] - a->thread_run_ns[j];
            wr.thread_tid = b->thread_tid[i];
          }
      if (wr.thread_tid >= 0) {
        ProcFile comm("/proc/self/task/" + std::to_string(wr.thread_tid) + "/comm");
        if (comm.read(buf)) {
          wr.thread_name.assign(buf.data(), comm.len());
          while (!wr.thread_name.empty() && is_space(wr.thread_name.back())) wr.thread_name.pop_back();
        }
      }
    }
    auto it = std::lower_bound(stats.worst.begin(), stats.worst.end(), wr,
                               [](const WakeStats::Worst& x, const WakeStats::Worst& y) { return x.s.late_s > y.s.late_s; });
    stats.worst.insert(it, wr);
    if (stats.worst.size() > 8) stats.worst.pop_back();
  }

  void run(std::int64_t period_ns_sample) {
    Sample first;
    const long hz = ::sysconf(_SC_CLK_TCK);
    tick_s = hz > 0 ? 1.0 / static_cast<double>(hz) : 0.01;
    start_ns = mono_ns();
    rescan_threads();
    sample(first, true);
    history.push_back(first);
    std::int64_t next = first.t_ns;
    std::int64_t last_ticks = first.t_ns, last_rescan = first.t_ns;
    std::vector<WakeEvent> got;
    got.reserve(256);
    bool stopping = false;
    for (;;) {
      next += period_ns_sample;
      const std::int64_t now = mono_ns();
      if (next < now) next = now;
      timespec ts{static_cast<time_t>(next / 1000000000LL), static_cast<long>(next % 1000000000LL)};
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
      }
      Sample s;
      const std::int64_t t = mono_ns();
      const bool ticks = t - last_ticks >= 10000000LL || !pending.empty();
      if (ticks) last_ticks = t;
      if (sample(s, ticks)) {
        history.push_back(s);
        ++stats.samples;
        while (history.size() > 4096 || (history.size() > 2 && s.t_ns - history.front().t_ns > 2000000000LL))
          history.pop_front();
      }
      if (t - last_rescan > 1000000000LL) {
        last_rescan = t;
        rescan_threads();
      }
      got.clear();
      events.consume(256, [&](const WakeEvent* p, std::size_t n) { got.insert(got.end(), p, p + n); });
      for (const WakeEvent& e : got) pending.push_back(e);
      // Attribute what the samples now cover (a sample taken after the wake-up).
      while (!pending.empty() && (pending.front().deadline_ns + pending.front().late_ns <= history.back().t_ns || stopping)) {
        attribute(pending.front());
        pending.pop_front();
      }
      if (stopping) break;
      if (stop.load(std::memory_order_acquire)) stopping = true;  // one more sample covers the last ones
    }
    const Sample& a = history.front();
    const Sample& b = history.back();
    (void)a;
    stats.window_s = 1e-9 * static_cast<double>(b.t_ns - start_ns);
    stats.cpu_steal_ms = d_ticks(first.ticks.steal, b.ticks.steal, tick_s) * 1e3;
    stats.cpu_irq_ms = d_ticks(first.ticks.irq + first.ticks.softirq, b.ticks.irq + b.ticks.softirq, tick_s) * 1e3;
    stats.engine_wait_ms = 1e-6 * static_cast<double>(b.engine.wait_ns - first.engine.wait_ns);
    if (first.have_cpu_sched && b.have_cpu_sched)
      stats.cpu_others_run_ms = std::max(0.0, 1e-6 * static_cast<double>(b.cpu_sched.run_ns - first.cpu_sched.run_ns) -
                                                  1e-6 * static_cast<double>(b.engine.run_ns - first.engine.run_ns));
    else
      stats.cpu_others_run_ms = 1e-6 * static_cast<double>(b.ours_run_ns - first.ours_run_ns);
    stats.dropped = dropped.load();
  }
};

WakeMonitor::WakeMonitor() : WakeMonitor(Options{}) {}
WakeMonitor::WakeMonitor(const Options& o) : opt_(o), impl_(std::make_unique<Impl>(o.ring)) {}
WakeMonitor::~WakeMonitor() { stop(); }

Status WakeMonitor::start(int tid, int cpu) {
  if (impl_->thread.joinable()) return Error{"wake monitor: already running"};
  if (cpu < 0) return Error{"wake monitor: the engine is not pinned to a CPU (cpu " + std::to_string(cpu) + ")"};
  Impl& m = *impl_;
  m.tid = tid;
  m.cpu = cpu;
  m.period_ns = 1000000;
  m.engine_schedstat = ProcFile("/proc/self/task/" + std::to_string(tid) + "/schedstat");
  m.proc_stat = ProcFile("/proc/stat");
  m.proc_schedstat = ProcFile("/proc/schedstat");  // absent without CONFIG_SCHEDSTATS: then only our threads are seen
  for (const ProcFile* f : {&m.engine_schedstat, &m.proc_stat}) {
    if (!f->open()) {
      m.stats.note = "cannot read " + f->path() + ": " + std::strerror(errno);
      return Error{"wake monitor: " + m.stats.note};
    }
  }
  if (!m.engine_schedstat.read(m.buf)) return Error{"wake monitor: cannot read " + m.engine_schedstat.path()};
  if (auto r = parse_task_schedstat(std::string_view(m.buf.data(), m.engine_schedstat.len())); !r)
    return Error{"wake monitor: " + m.engine_schedstat.path() + ": " + r.error()};
  if (!m.proc_stat.read(m.buf)) return Error{"wake monitor: cannot read /proc/stat"};
  if (auto r = parse_proc_stat_cpu(std::string_view(m.buf.data(), m.proc_stat.len()), cpu); !r)
    return Error{"wake monitor: " + r.error()};
  m.stats.available = true;
  m.stats.tid = tid;
  m.stats.cpu = cpu;
  m.stats.note = std::string("engine thread schedstat, /proc/stat cpu") + std::to_string(cpu) +
                 (m.proc_schedstat.open() ? ", /proc/schedstat" : " (no /proc/schedstat: other processes' run time unseen)") +
                 ", our threads on that CPU";
  const auto period = static_cast<std::int64_t>(opt_.period_s * 1e9);
  m.thread = std::thread([&m, period] { m.run(period); });
  return {};
}

void WakeMonitor::stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->stop.store(true, std::memory_order_release);
  impl_->thread.join();
}

void WakeMonitor::push(const WakeEvent& e) noexcept {
  if (!impl_->events.try_push(e)) impl_->dropped.fetch_add(1, std::memory_order_relaxed);
}

WakeStats WakeMonitor::stats() const {
  WakeStats s = impl_->stats;
  s.dropped = impl_->dropped.load();
  return s;
}

}  // namespace dentar::haptics
