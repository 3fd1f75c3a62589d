// The drill's sound, synthesised (no recordings): an air-turbine handpiece
// whose speed follows the pedal and the cutting load, and a modal/granular
// cutting voice per material under the bur (docs/sound.md: the model and
// every parameter with its source or reason).
//
//   pedal ──▶ speed s (spin-up / spin-down time constants; load lowers the target)
//   force, material ──▶ load = friction_m · F / stall_force_N ──▶ s_target = 1 − load
//   s ──▶ whine: harmonics of f0 = s · free_speed_rpm / 60, level ∝ s²; exhaust hiss ∝ s
//   cutting ──▶ grains (Poisson, rate ∝ F) exciting the material's resonator + noise
//   contact onset ──▶ transient (drill running) or probe tick (drill stopped)
//
// Deterministic: the same inputs at the same block boundaries give the same
// samples (own PRNG, no clocks, no threads).
// Thread: a DrillSynth belongs to one thread (the audio thread or an offline
// render). set_input() and render() never allocate, lock or wait; only the
// constructor allocates (a copy of the optional user sample).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace dentar::sound {

// Labels are volume::Material's (0 air, 1 enamel, 2 dentin, 3 pulp, 4 caries,
// 5 restoration); 6 and 7 are unused and silent.
inline constexpr int kSoundMaterials = 8;

// How one material sounds under the bur.
struct MaterialSound {
  const char* name = "";
  double friction = 0;        // load per newton relative to enamel (1): how much it slows the bur
  double grain_rate_hz = 0;   // cutting grains per second at reference_force_N
  double grain_level = 0;     // grain impulse amplitude (0..1)
  double mode_hz = 1000;      // the resonance a grain excites
  double mode_decay_s = 1e-3; // 1/e decay time of that resonance
  double noise_level = 0;     // broadband cutting noise through the resonance, at reference_force_N
};

struct DrillParams {
  double sample_rate_hz = 48000;
  // Handpiece: a high-speed air turbine.
  double free_speed_rpm = 320000;  // free-running speed (fundamental 5333 Hz)
  double stall_force_N = 4.0;      // force at which enamel (friction 1) would stop the bur
  double min_speed_fraction = 0.3; // the turbine never stalls in the model
  double spin_up_s = 0.08;         // 1/e time constant of acceleration (pedal pressed, load released)
  double spin_down_s = 0.35;       // 1/e time constant, pedal released (the turbine coasts)
  double load_response_s = 0.015;  // 1/e time constant of slowing under load
  int harmonics = 4;               // whine partials (those above 0.45·fs are left out)
  double harmonic_rolloff = 0.45;  // partial k has amplitude rolloff^(k-1)
  double whine_level = 0.22;       // at free speed
  double hiss_level = 0.035;       // exhaust air at free speed
  double reference_force_N = 1.0;
  double cut_hold_s = 0.04;        // cutting voice stays this long after the last removal
  double contact_level = 0.6;      // first-contact transient (drill running)
  double probe_level = 0.5;        // probe tick (drill stopped)
  double probe_mode_hz = 4200;     // steel tip on enamel
  double probe_decay_s = 0.003;
  double gain = 0.7;               // master gain (0..1): --volume
  // Sound as a teacher (issue 29), off by default: while the force exceeds this limit a
  // pulsed pure tone (teacher_tone_hz, far below the whine's 1.6-5.3 kHz and without its
  // partials) beeps, faster the further above: 4 Hz at the limit, +12 Hz per newton over
  // it, up to 16 Hz. 0 = off.
  double teacher_force_limit_N = 0;
  double teacher_tone_hz = 880;
  double teacher_level = 0.2;
  std::array<MaterialSound, kSoundMaterials> materials{};
  // Optional user sample of the running drill (mono, at sample_rate_hz), looped and
  // resampled by the speed instead of the synthesised whine; recorded at user_sample_rpm.
  std::vector<float> user_sample;
  double user_sample_rpm = 320000;
  std::string validate() const;  // empty when valid, else names the field and the constraint
};

// The documented defaults (docs/sound.md).
DrillParams default_drill_params();

// What the sound needs from the haptic side, per block. Built from the
// engine's HapticSnapshot or from a session log's StepRecord (feed.h).
struct DrillInput {
  double time_s = 0;
  bool pedal = false;
  bool contact = false;
  bool fault = false;  // device fault or watchdog: the drill stops (zero force)
  double force_N = 0;  // magnitude of the force sent to the device
  // Material removed since the previous input, per label; any unit, only the
  // proportions and "> 0" matter.
  double removed[kSoundMaterials] = {};
  bool pulp_exposed = false;
};

class DrillSynth {
 public:
  explicit DrillSynth(DrillParams params, std::uint64_t seed = 1);

  // The state for the samples rendered next. Detects contact onsets.
  void set_input(const DrillInput& in) noexcept;
  // Writes `frames` mono samples in [-1, 1].
  void render(float* out, std::size_t frames) noexcept;

  // Observers (tests, HUD): speed as a fraction of free speed, the fundamental,
  // the material the cutting voice uses (-1: none), onsets so far.
  double speed_fraction() const { return speed_; }
  double fundamental_hz() const { return speed_ * p_.free_speed_rpm / 60.0; }
  int cutting_material() const { return cut_active_ ? material_ : -1; }
  std::uint64_t contact_onsets() const { return onsets_; }
  std::uint64_t probe_ticks() const { return ticks_; }
  // Samples during which the teacher's beep sounded (its gate open).
  std::uint64_t teacher_samples() const { return teacher_samples_; }
  const DrillParams& params() const { return p_; }

 private:
  struct Resonator {  // two-pole resonator, unit-ish impulse response
    double a1 = 0, a2 = 0, in_gain = 0, y1 = 0, y2 = 0;
    void tune(double f_hz, double decay_s, double fs);
    double tick(double x) noexcept {
      const double y = in_gain * x + a1 * y1 - a2 * y2;
      y2 = y1;
      y1 = y;
      return y;
    }
    void flush_tiny() noexcept {
      if (y1 < 1e-9 && y1 > -1e-9 && y2 < 1e-9 && y2 > -1e-9) y1 = y2 = 0;
    }
  };
  double uniform() noexcept;  // [0, 1)
  double noise() noexcept { return 2.0 * uniform() - 1.0; }

  DrillParams p_;
  std::uint64_t rng_;
  double dt_;
  // Inputs (block rate).
  DrillInput in_{};
  bool had_contact_ = false;
  double since_removal_s_ = 1e9;
  int material_ = 1;
  // State (sample rate).
  double speed_ = 0, phase_ = 0, cut_level_ = 0, user_pos_ = 0;
  bool cut_active_ = false;
  double pending_contact_ = 0, pending_tick_ = 0;
  std::array<Resonator, kSoundMaterials> modes_{};
  Resonator probe_;
  double hiss_lp_ = 0;
  double teach_phase_ = 0, teach_pulse_ = 0, teach_env_ = 0;
  std::uint64_t teacher_samples_ = 0;
  std::uint64_t onsets_ = 0, ticks_ = 0;
};

}  // namespace dentar::sound
