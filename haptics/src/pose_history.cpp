#include "dentar/haptics/pose_history.h"

#include <cmath>
#include <cstring>

namespace dentar::haptics {

PoseHistory::PoseHistory() {
  for (auto& s : slots_)
    for (auto& w : s.words) w.store(0, std::memory_order_relaxed);
}

void PoseHistory::push(double time_s, const Eigen::Isometry3d& T_dev_sty, bool valid) noexcept {
  Entry e;
  const bool finite = std::isfinite(time_s) && T_dev_sty.matrix().allFinite();
  // Times never go back: the search needs them sorted.
  e.t = std::isfinite(time_s) && time_s > newest_t_ ? time_s : newest_t_;
  if (newest_t_ == -1e300 && !std::isfinite(time_s)) e.t = 0;
  newest_t_ = e.t;
  if (finite) {
    const Eigen::Vector3d p = T_dev_sty.translation();
    Eigen::Quaterniond q(T_dev_sty.linear());
    q.normalize();
    e.p[0] = p.x();
    e.p[1] = p.y();
    e.p[2] = p.z();
    e.q[0] = q.w();
    e.q[1] = q.x();
    e.q[2] = q.y();
    e.q[3] = q.z();
  }
  e.valid = valid && finite ? 1.0 : 0.0;
  std::uint64_t buf[kWords];
  std::memcpy(buf, &e, sizeof(Entry));
  const std::uint64_t i = count_.load(std::memory_order_relaxed);
  Slot& s = slots_[i % kCapacity];
  s.seq.store(2 * i + 1, std::memory_order_relaxed);  // odd: being written
  // Release stores keep the odd stamp ahead of every data word (as SeqLock does).
  for (std::size_t k = 0; k < kWords; ++k) s.words[k].store(buf[k], std::memory_order_release);
  s.seq.store(2 * i + 2, std::memory_order_release);
  count_.store(i + 1, std::memory_order_release);
}

bool PoseHistory::read(std::uint64_t index, Entry& e) const noexcept {
  const Slot& s = slots_[index % kCapacity];
  const std::uint64_t want = 2 * index + 2;
  if (s.seq.load(std::memory_order_acquire) != want) return false;
  std::uint64_t buf[kWords];
  for (std::size_t k = 0; k < kWords; ++k) buf[k] = s.words[k].load(std::memory_order_acquire);
  if (s.seq.load(std::memory_order_relaxed) != want) return false;
  std::memcpy(&e, buf, sizeof(Entry));
  return true;
}

Eigen::Isometry3d PoseHistory::pose(const Entry& e) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(e.q[0], e.q[1], e.q[2], e.q[3]).toRotationMatrix();
  T.translation() = Eigen::Vector3d(e.p[0], e.p[1], e.p[2]);
  return T;
}

Eigen::Isometry3d PoseHistory::blend(const Entry& a, const Entry& b, double w) {
  const Eigen::Quaterniond qa(a.q[0], a.q[1], a.q[2], a.q[3]), qb(b.q[0], b.q[1], b.q[2], b.q[3]);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = qa.slerp(w, qb).toRotationMatrix();
  for (int k = 0; k < 3; ++k) T.translation()[k] = (1 - w) * a.p[k] + w * b.p[k];
  return T;
}

PoseHistory::Sample PoseHistory::at_index(double x) const noexcept {
  Sample out;
  if (!std::isfinite(x) || x < 0 || x > 1e15) return out;
  const auto i = static_cast<std::uint64_t>(std::floor(x));
  const double w = x - static_cast<double>(i);
  const std::uint64_t n = count_.load(std::memory_order_acquire);
  if (n == 0) return out;
  Entry a, b;
  const bool need_b = w > 0;
  if (i >= n) {  // not pushed yet: the newest
    if (!read(n - 1, a)) return out;
    out.lookup = a.valid != 0 ? Lookup::kAfterNewest : Lookup::kInvalid;
    out.index = static_cast<double>(n - 1);
  } else if (!read(i, a)) {
    out.lookup = Lookup::kBeforeOldest;  // overwritten
    return out;
  } else if (need_b && (i + 1 >= n || !read(i + 1, b))) {
    out.lookup = a.valid != 0 ? Lookup::kAfterNewest : Lookup::kInvalid;
    out.index = static_cast<double>(i);
  } else {
    out.index = x;
    out.t0_s = a.t;
    out.t1_s = need_b ? b.t : a.t;
    if (a.valid == 0 || (need_b && b.valid == 0)) {
      out.lookup = Lookup::kInvalid;
      return out;
    }
    out.lookup = Lookup::kInterpolated;
    out.T_dev_sty = need_b ? blend(a, b, w) : pose(a);
    return out;
  }
  out.t0_s = out.t1_s = a.t;
  if (out.lookup != Lookup::kInvalid) out.T_dev_sty = pose(a);
  return out;
}

PoseHistory::Sample PoseHistory::latest() const noexcept {
  Sample out;
  for (int attempt = 0; attempt < 4; ++attempt) {
    const std::uint64_t n = count_.load(std::memory_order_acquire);
    if (n == 0) return out;
    Entry e;
    if (!read(n - 1, e)) continue;  // lapped between the two loads
    out.t0_s = out.t1_s = e.t;
    out.index = static_cast<double>(n - 1);
    if (e.valid == 0) {
      out.lookup = Lookup::kInvalid;
      return out;
    }
    out.lookup = Lookup::kInterpolated;
    out.T_dev_sty = pose(e);
    return out;
  }
  return out;
}

PoseHistory::Sample PoseHistory::sample(double t_s) const noexcept {
  Sample out;
  if (!std::isfinite(t_s)) return out;
  for (int attempt = 0; attempt < 4; ++attempt) {
    const std::uint64_t n = count_.load(std::memory_order_acquire);
    if (n == 0) return out;
    const std::uint64_t newest = n - 1;
    Entry hi;
    if (!read(newest, hi)) continue;  // the writer lapped the ring since the count was read
    if (t_s >= hi.t) {
      out.t0_s = out.t1_s = hi.t;
      out.index = static_cast<double>(newest);
      if (hi.valid == 0) {
        out.lookup = Lookup::kInvalid;
        return out;
      }
      out.T_dev_sty = pose(hi);
      out.lookup = t_s == hi.t ? Lookup::kInterpolated : Lookup::kAfterNewest;
      out.age_s = t_s - hi.t;
      return out;
    }
    // The first index whose time is after t_s. Slots already overwritten read as gone and
    // count as "not after t_s": they are the oldest ones, so the predicate stays monotonic.
    const std::uint64_t oldest = n > kCapacity ? n - kCapacity : 0;
    std::uint64_t lo = oldest, hi_i = newest;
    Entry e;
    while (lo < hi_i) {
      const std::uint64_t mid = lo + (hi_i - lo) / 2;
      if (read(mid, e) && e.t > t_s)
        hi_i = mid;
      else
        lo = mid + 1;
    }
    Entry b;
    if (!read(lo, b)) continue;  // overwritten meanwhile: search again
    Entry a;
    if (lo == oldest || !read(lo - 1, a)) {
      out.lookup = Lookup::kBeforeOldest;
      out.t0_s = out.t1_s = b.t;
      out.index = static_cast<double>(lo);
      if (b.valid == 0) {
        out.lookup = Lookup::kInvalid;
        return out;
      }
      out.T_dev_sty = pose(b);
      return out;
    }
    out.t0_s = a.t;
    out.t1_s = b.t;
    const double w = (t_s - a.t) / (b.t - a.t);  // b.t > t_s >= a.t
    out.index = static_cast<double>(lo - 1) + w;
    if (a.valid == 0 || b.valid == 0) {
      out.lookup = Lookup::kInvalid;
      if (a.valid != 0) out.T_dev_sty = pose(a);
      if (b.valid != 0) out.T_dev_sty = pose(b);
      return out;
    }
    out.T_dev_sty = blend(a, b, w);
    out.lookup = Lookup::kInterpolated;
    return out;
  }
  return out;  // kEmpty: the writer lapped the whole ring on every attempt
}

const char* lookup_name(PoseHistory::Lookup l) {
  switch (l) {
    case PoseHistory::Lookup::kInterpolated: return "interpolated";
    case PoseHistory::Lookup::kAfterNewest: return "after the newest pose";
    case PoseHistory::Lookup::kBeforeOldest: return "before the oldest pose";
    case PoseHistory::Lookup::kInvalid: return "invalid pose (device fault)";
    case PoseHistory::Lookup::kEmpty: return "empty";
  }
  return "?";
}

}  // namespace dentar::haptics
