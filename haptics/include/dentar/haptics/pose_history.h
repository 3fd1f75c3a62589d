// PoseHistory: the last kCapacity stylus poses of the haptic device with their times, so that
// a camera frame can be drawn with the stylus pose of its exposure instead of the pose of the
// moment the frame path got to it (issue 24: 33 ms of camera latency at 20 mm/s of stylus
// motion is 0.66 mm of co-location error).
//
// Threads: one writer (the 1 kHz haptic thread: push() is wait-free, allocates nothing, takes
// no lock and never waits for a reader), any number of readers (the frame path: sample() and
// latest() are lock-free; they never make the writer wait, and a reader never spins: a slot the
// writer overwrites while it is read counts as gone, and the lookup says so).
// Each slot is a small seqlock stamped with the push's index (2 i + 2 when complete), so a
// reader can tell a complete entry of push i from one half-written or one of a later lap.
//
// Times: whatever clock the writer stamps with, seconds, non-decreasing (Engine: CLOCK_MONOTONIC
// = std::chrono::steady_clock = ar::steady_now_s() when its thread runs, the device's simulated
// time under run_steps()). A push with a time before the newest one's is stored as the newest
// one's time (a clock step back must not break the search).
// Poses: T_dev_sty (metres); rotation as a unit quaternion, interpolated by slerp, translation
// linearly.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <atomic>
#include <cstdint>

namespace dentar::haptics {

class PoseHistory {
 public:
  // 1.024 s at 1 kHz: a camera latency plus a frame path that falls a few frames behind.
  static constexpr std::size_t kCapacity = 1024;

  enum class Lookup : std::uint8_t {
    kInterpolated,  // t lies between two stored poses (or on one): pose interpolated
    kAfterNewest,   // t is after the newest pose: the newest pose (the device has not reported
                    // that time yet, or it stopped); age_s says how far
    kBeforeOldest,  // t is older than anything still stored: the oldest pose read
    kInvalid,       // a bracketing pose was stored as invalid (device fault): the nearest valid
                    // one is not searched; pose = the other bracket when valid, else identity
    kEmpty,         // nothing pushed yet (or every read raced the writer: see sample())
  };

  struct Sample {
    Lookup lookup = Lookup::kEmpty;
    Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
    double t0_s = 0, t1_s = 0;  // the bracketing poses' times (equal when one pose was used)
    double age_s = 0;           // kAfterNewest: t minus the newest time; else 0
    // The pose's place in the push sequence: push index of the earlier bracket + the weight of
    // the later one (Engine: the step index, fractional). A replay that pushed the same
    // sequence gets the same pose back from at_index() (offline replays of live recordings).
    // -1 for kEmpty.
    double index = -1;
    // True for kInterpolated and kAfterNewest (a pose the caller can draw); false otherwise.
    bool usable() const { return lookup == Lookup::kInterpolated || lookup == Lookup::kAfterNewest; }
  };

  PoseHistory();
  PoseHistory(const PoseHistory&) = delete;
  PoseHistory& operator=(const PoseHistory&) = delete;

  // Writer thread only. Wait-free; no allocation; never waits for a reader. A non-finite time
  // or pose is stored as invalid.
  void push(double time_s, const Eigen::Isometry3d& T_dev_sty, bool valid = true) noexcept;

  // Any thread. The pose at time t_s: interpolated between the two stored poses around it.
  // Lock-free and bounded: O(log kCapacity) slot reads; retries at most a few times when the
  // writer laps the whole ring during the call (a reader descheduled for > 1 s).
  Sample sample(double t_s) const noexcept;
  // Any thread. The pose at a fractional push index (Sample::index of an earlier lookup, in
  // this or a replayed history): interpolated between pushes floor(x) and floor(x) + 1 with the
  // weight x - floor(x). kBeforeOldest / kAfterNewest (with that push's pose) when one of the
  // two is no longer / not yet stored; kEmpty for x < 0 or not finite.
  Sample at_index(double x) const noexcept;
  // Any thread. The newest complete pose (lookup kInterpolated, t0 = t1 = its time; kInvalid
  // when it was stored invalid), or kEmpty.
  Sample latest() const noexcept;

  // Pushes so far (any thread).
  std::uint64_t pushes() const noexcept { return count_.load(std::memory_order_acquire); }

 private:
  struct Entry {
    double t = 0;
    double p[3] = {0, 0, 0};
    double q[4] = {1, 0, 0, 0};  // w x y z
    double valid = 0;            // 1 or 0 (a double: every word of the slot is one 8-byte word)
  };
  static constexpr std::size_t kWords = sizeof(Entry) / 8;
  static_assert(sizeof(Entry) % 8 == 0);
  struct Slot {
    std::atomic<std::uint64_t> seq{0};  // 2 i + 1 while push i writes, 2 i + 2 when complete
    std::atomic<std::uint64_t> words[kWords];
  };
  // Reads entry `index` into e; false when its slot does not hold that complete entry.
  bool read(std::uint64_t index, Entry& e) const noexcept;
  static Eigen::Isometry3d pose(const Entry& e);
  // a + w (b - a): translation linear, rotation slerp; w in [0, 1].
  static Eigen::Isometry3d blend(const Entry& a, const Entry& b, double w);

  std::array<Slot, kCapacity> slots_;
  std::atomic<std::uint64_t> count_{0};
  double newest_t_ = -1e300;  // writer only
};

static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
              "PoseHistory needs lock-free 64-bit atomics (the haptic thread must not lock)");

const char* lookup_name(PoseHistory::Lookup l);

}  // namespace dentar::haptics
