#include "dentar/live/pen_device.h"

#include <time.h>

#include <cmath>

namespace dentar::live {
namespace {
double steady_now() noexcept {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);  // std::chrono::steady_clock's clock on Linux
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

void PenDevice::publish(const Eigen::Isometry3d& T_dev_sty, bool valid, double steady_s) noexcept {
  Pose p{};
  const Eigen::Matrix4d m = T_dev_sty.matrix();
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) p.T[c * 4 + r] = m(r, c);
  p.steady_s = steady_s;
  p.valid = valid && m.allFinite();
  pose_.store(p);
}

bool PenDevice::read(haptics::DeviceState& out) noexcept {
  const Pose p = pose_.load();
  const double now = steady_now();
  out.time_s = now;
  out.buttons = 0;
  out.pedal = false;  // the pedal comes from a Pedal (haptics/pedal.h)
  if (!p.valid || now - p.steady_s > stale_s_) {
    out.fault = true;
    out.velocity_m_per_s.setZero();
    return false;
  }
  Eigen::Matrix4d m;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) m(r, c) = p.T[c * 4 + r];
  out.T_dev_sty.linear() = m.topLeftCorner<3, 3>();
  out.T_dev_sty.translation() = m.topRightCorner<3, 1>();
  // Velocity from successive camera poses (held between frames: zero then).
  const Eigen::Vector3d pos = out.T_dev_sty.translation();
  if (prev_t_ >= 0 && p.steady_s > prev_t_)
    out.velocity_m_per_s = (pos - prev_pos_) / (p.steady_s - prev_t_);
  else if (prev_t_ < 0)
    out.velocity_m_per_s.setZero();
  if (p.steady_s != prev_t_) {
    prev_pos_ = pos;
    prev_t_ = p.steady_s;
  }
  out.fault = false;
  return true;
}

void PenDevice::write_force(const Eigen::Vector3d& f) noexcept {
  fx_.store(f.x(), std::memory_order_relaxed);
  fy_.store(f.y(), std::memory_order_relaxed);
  fz_.store(f.z(), std::memory_order_relaxed);
}

Eigen::Vector3d PenDevice::last_force() const noexcept {
  return {fx_.load(std::memory_order_relaxed), fy_.load(std::memory_order_relaxed),
          fz_.load(std::memory_order_relaxed)};
}

}  // namespace dentar::live
