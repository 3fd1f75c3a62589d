#include "dentar/sound/drill_synth.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace dentar::sound {
namespace {

constexpr double kTwoPi = 6.283185307179586;

std::string field_error(const std::string& field, double v, const std::string& constraint) {
  std::ostringstream s;
  s << field << " = " << v << " must be " << constraint;
  return s.str();
}

bool finite_pos(double v) { return std::isfinite(v) && v > 0; }
bool finite_nonneg(double v) { return std::isfinite(v) && v >= 0; }

}  // namespace

DrillParams default_drill_params() {
  DrillParams p;
  auto& m = p.materials;
  m[0] = {"air", 0.0, 0, 0, 1000, 1e-3, 0};
  m[1] = {"enamel", 1.0, 2500, 0.30, 4800, 0.0008, 0.05};
  m[2] = {"dentin", 0.6, 1200, 0.20, 2200, 0.0015, 0.03};
  m[3] = {"pulp", 0.08, 100, 0.05, 700, 0.003, 0.01};
  m[4] = {"caries", 0.35, 600, 0.12, 1500, 0.002, 0.02};
  m[5] = {"restoration", 1.1, 3000, 0.30, 5500, 0.0006, 0.06};
  m[6] = {"unused", 0, 0, 0, 1000, 1e-3, 0};
  m[7] = {"unused", 0, 0, 0, 1000, 1e-3, 0};
  return p;
}

std::string DrillParams::validate() const {
  if (!(std::isfinite(sample_rate_hz) && sample_rate_hz >= 8000 && sample_rate_hz <= 192000))
    return field_error("sample_rate_hz", sample_rate_hz, "in [8000, 192000] Hz");
  if (!finite_pos(free_speed_rpm)) return field_error("free_speed_rpm", free_speed_rpm, "finite and > 0");
  if (!finite_pos(stall_force_N)) return field_error("stall_force_N", stall_force_N, "finite and > 0");
  if (!(min_speed_fraction >= 0 && min_speed_fraction < 1))
    return field_error("min_speed_fraction", min_speed_fraction, "in [0, 1)");
  for (auto [n, v] : {std::pair{"spin_up_s", spin_up_s}, std::pair{"spin_down_s", spin_down_s},
                      std::pair{"load_response_s", load_response_s}, std::pair{"probe_decay_s", probe_decay_s},
                      std::pair{"reference_force_N", reference_force_N}, std::pair{"probe_mode_hz", probe_mode_hz}})
    if (!finite_pos(v)) return field_error(n, v, "finite and > 0");
  for (auto [n, v] : {std::pair{"whine_level", whine_level}, std::pair{"hiss_level", hiss_level},
                      std::pair{"contact_level", contact_level}, std::pair{"probe_level", probe_level},
                      std::pair{"cut_hold_s", cut_hold_s}, std::pair{"harmonic_rolloff", harmonic_rolloff}})
    if (!finite_nonneg(v)) return field_error(n, v, "finite and >= 0");
  if (!(gain >= 0 && gain <= 1)) return field_error("gain", gain, "in [0, 1] (volume 0-100 %)");
  if (harmonics < 1 || harmonics > 16)
    return field_error("harmonics", harmonics, "in [1, 16]");
  if (probe_mode_hz >= 0.5 * sample_rate_hz)
    return field_error("probe_mode_hz", probe_mode_hz, "below half the sample rate");
  for (int i = 0; i < kSoundMaterials; ++i) {
    const auto& m = materials[static_cast<std::size_t>(i)];
    const std::string f = "materials[" + std::to_string(i) + "].";
    if (!finite_nonneg(m.friction)) return field_error(f + "friction", m.friction, "finite and >= 0");
    if (!finite_nonneg(m.grain_rate_hz)) return field_error(f + "grain_rate_hz", m.grain_rate_hz, "finite and >= 0");
    if (!finite_nonneg(m.grain_level)) return field_error(f + "grain_level", m.grain_level, "finite and >= 0");
    if (!finite_nonneg(m.noise_level)) return field_error(f + "noise_level", m.noise_level, "finite and >= 0");
    if (!(finite_pos(m.mode_hz) && m.mode_hz < 0.5 * sample_rate_hz))
      return field_error(f + "mode_hz", m.mode_hz, "> 0 and below half the sample rate");
    if (!finite_pos(m.mode_decay_s)) return field_error(f + "mode_decay_s", m.mode_decay_s, "finite and > 0");
  }
  if (!finite_nonneg(teacher_force_limit_N))
    return field_error("teacher_force_limit_N", teacher_force_limit_N, "finite and >= 0 (0 = off)");
  if (!finite_nonneg(teacher_level)) return field_error("teacher_level", teacher_level, "finite and >= 0");
  if (!(finite_pos(teacher_tone_hz) && teacher_tone_hz < 0.5 * sample_rate_hz))
    return field_error("teacher_tone_hz", teacher_tone_hz, "> 0 and below half the sample rate");
  if (!user_sample.empty() && !finite_pos(user_sample_rpm))
    return field_error("user_sample_rpm", user_sample_rpm, "finite and > 0");
  return {};
}

void DrillSynth::Resonator::tune(double f_hz, double decay_s, double fs) {
  const double r = std::exp(-1.0 / (decay_s * fs));
  const double w = kTwoPi * f_hz / fs;
  a1 = 2.0 * r * std::cos(w);
  a2 = r * r;
  in_gain = std::sin(w);  // impulse response r^n sin((n+1) w): peak about 1
  y1 = y2 = 0;
}

DrillSynth::DrillSynth(DrillParams params, std::uint64_t seed)
    : p_(std::move(params)), rng_(seed * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull) {
  dt_ = 1.0 / p_.sample_rate_hz;
  for (int i = 0; i < kSoundMaterials; ++i) {
    const auto& m = p_.materials[static_cast<std::size_t>(i)];
    modes_[static_cast<std::size_t>(i)].tune(m.mode_hz, m.mode_decay_s, p_.sample_rate_hz);
  }
  probe_.tune(p_.probe_mode_hz, p_.probe_decay_s, p_.sample_rate_hz);
}

double DrillSynth::uniform() noexcept {
  // xorshift64*: deterministic, allocation-free.
  rng_ ^= rng_ >> 12;
  rng_ ^= rng_ << 25;
  rng_ ^= rng_ >> 27;
  return static_cast<double>((rng_ * 0x2545F4914F6CDD1Dull) >> 11) * (1.0 / 9007199254740992.0);
}

void DrillSynth::set_input(const DrillInput& in) noexcept {
  const double elapsed = std::max(0.0, in.time_s - in_.time_s);
  int best = -1;
  double best_v = 0;
  for (int i = 1; i < kSoundMaterials; ++i) {
    const double v = in.removed[i];
    if (v > best_v) {
      best_v = v;
      best = i;
    }
  }
  if (best >= 0) {
    material_ = best;
    since_removal_s_ = 0;
  } else {
    since_removal_s_ += elapsed;
  }
  const bool contact = in.contact && !in.fault;
  if (contact && !had_contact_) {
    ++onsets_;
    if (speed_ > 0.1) {
      pending_contact_ = p_.contact_level;  // the bur strikes the surface
    } else {
      pending_tick_ = p_.probe_level;  // the drill is off: a probe's tick
      ++ticks_;
    }
  }
  had_contact_ = contact;
  in_ = in;
  in_.contact = contact;
}

void DrillSynth::render(float* out, std::size_t frames) noexcept {
  const MaterialSound& mat = p_.materials[static_cast<std::size_t>(material_)];
  const bool drive = in_.pedal && !in_.fault;
  const double force = std::isfinite(in_.force_N) ? std::max(0.0, in_.force_N) : 0.0;
  const double load = in_.contact ? mat.friction * force / p_.stall_force_N : 0.0;
  const double target = drive ? std::max(p_.min_speed_fraction, 1.0 - load) : 0.0;
  const double k_up = 1.0 - std::exp(-dt_ / p_.spin_up_s);
  const double k_down = 1.0 - std::exp(-dt_ / p_.spin_down_s);
  const double k_load = 1.0 - std::exp(-dt_ / p_.load_response_s);
  const double k_cut = 1.0 - std::exp(-dt_ / 0.005);
  const double k_burst = std::exp(-dt_ / 0.002);
  cut_active_ = drive && in_.contact && since_removal_s_ <= p_.cut_hold_s;
  // Cutting level grows with the square root of the force (more grains, not only louder ones).
  const double cut_target = cut_active_ ? std::min(2.0, std::sqrt(force / p_.reference_force_N)) : 0.0;
  const double nyquist_guard = 0.45 * p_.sample_rate_hz;
  Resonator& mode = modes_[static_cast<std::size_t>(material_)];
  const bool user = !p_.user_sample.empty();
  const double user_len = static_cast<double>(p_.user_sample.size());

  // The teacher: force above the limit (contact or not: the force is what the student feels).
  const bool teach = p_.teacher_force_limit_N > 0 && !in_.fault && force > p_.teacher_force_limit_N;
  const double pulse_hz = teach ? std::min(16.0, 4.0 + 12.0 * (force - p_.teacher_force_limit_N)) : 0.0;
  const double k_gate = 1.0 - std::exp(-dt_ / 0.003);  // 3 ms ramps: no clicks

  for (std::size_t n = 0; n < frames; ++n) {
    // Speed: spin-up from rest, load changes, coasting down.
    double k;
    if (!drive) k = k_down;         // coasting
    else if (target >= speed_) k = k_up;  // the turbine accelerates (from rest, or load released)
    else k = k_load;                // the load brakes it
    speed_ += k * (target - speed_);
    if (!drive && speed_ < 1e-4) speed_ = 0;

    double y = 0;
    if (speed_ > 0) {
      const double f0 = speed_ * p_.free_speed_rpm / 60.0;
      const double amp = p_.whine_level * speed_ * speed_;
      if (user) {
        const auto i0 = static_cast<std::size_t>(user_pos_);
        const double fr = user_pos_ - static_cast<double>(i0);
        const std::size_t i1 = (i0 + 1) % p_.user_sample.size();
        y += amp * ((1.0 - fr) * p_.user_sample[i0] + fr * p_.user_sample[i1]);
        user_pos_ += speed_ * p_.free_speed_rpm / p_.user_sample_rpm;
        while (user_pos_ >= user_len) user_pos_ -= user_len;
      } else {
        phase_ += kTwoPi * f0 * dt_;
        if (phase_ >= kTwoPi) phase_ -= kTwoPi;
        double a = 1.0;
        for (int h = 1; h <= p_.harmonics && h * f0 < nyquist_guard; ++h) {
          y += amp * a * std::sin(h * phase_);
          a *= p_.harmonic_rolloff;
        }
      }
      // Exhaust hiss: white noise minus its low-passed self (a gentle high-pass).
      const double w = noise();
      hiss_lp_ += 0.15 * (w - hiss_lp_);
      y += p_.hiss_level * speed_ * (w - hiss_lp_);
    }

    // Cutting: grains and noise through the material's resonance, scaled by force and speed.
    cut_level_ += k_cut * (cut_target - cut_level_);
    double excite = 0;
    if (cut_level_ > 1e-4) {
      const double drive_level = cut_level_ * std::min(1.0, speed_ / p_.min_speed_fraction);
      if (uniform() < mat.grain_rate_hz * drive_level * dt_)
        excite += mat.grain_level * (0.5 + 0.5 * uniform()) * (uniform() < 0.5 ? -1.0 : 1.0);
      excite += mat.noise_level * drive_level * noise();
    } else {
      cut_level_ = cut_target > 0 ? cut_level_ : 0;
    }
    // First-contact transient: an impulse and a 2 ms noise burst into the same resonance.
    if (pending_contact_ > 0) {
      excite += pending_contact_ * noise();
      pending_contact_ *= k_burst;
      if (pending_contact_ < 1e-4) pending_contact_ = 0;
    }
    y += mode.tick(excite);
    // Other materials' resonances ring out after the material changes.
    for (int i = 0; i < kSoundMaterials; ++i)
      if (i != material_) {
        Resonator& r = modes_[static_cast<std::size_t>(i)];
        if (r.y1 != 0 || r.y2 != 0) y += r.tick(0);
      }
    // Probe tick: one impulse into the probe's resonance.
    if (pending_tick_ > 0 || probe_.y1 != 0 || probe_.y2 != 0) {
      y += probe_.tick(pending_tick_);
      pending_tick_ = 0;
    }
    // Teacher's beep: on for the first half of each pulse period.
    if (teach || teach_env_ > 0) {
      bool gate = false;
      if (teach) {
        teach_pulse_ += pulse_hz * dt_;
        if (teach_pulse_ >= 1.0) teach_pulse_ -= 1.0;
        gate = teach_pulse_ < 0.5;
      }
      teach_env_ += k_gate * ((gate ? 1.0 : 0.0) - teach_env_);
      if (!teach && teach_env_ < 1e-4) teach_env_ = 0;
      if (gate) ++teacher_samples_;
      teach_phase_ += kTwoPi * p_.teacher_tone_hz * dt_;
      if (teach_phase_ >= kTwoPi) teach_phase_ -= kTwoPi;
      y += p_.teacher_level * teach_env_ * std::sin(teach_phase_);
    }
    out[n] = static_cast<float>(p_.gain * std::tanh(y));
  }
  for (auto& r : modes_) r.flush_tiny();
  probe_.flush_tiny();
  if (speed_ == 0) hiss_lp_ = 0;
}

}  // namespace dentar::sound
