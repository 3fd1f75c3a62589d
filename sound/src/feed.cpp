#include "dentar/sound/feed.h"

#include <cmath>

#include "dentar/haptics/replay.h"

namespace dentar::sound {

DrillInput input_from_record(const haptics::StepRecord& r, double rate_hz) noexcept {
  DrillInput in;
  in.time_s = static_cast<double>(r.step) / rate_hz;
  in.pedal = r.pedal != 0;
  in.contact = (r.flags & haptics::kFlagContact) != 0;
  in.fault = (r.flags & (haptics::kFlagDeviceFault | haptics::kFlagWatchdog)) != 0;
  in.force_N = std::sqrt(r.force_dev_N[0] * r.force_dev_N[0] + r.force_dev_N[1] * r.force_dev_N[1] +
                         r.force_dev_N[2] * r.force_dev_N[2]);
  for (int i = 0; i < kSoundMaterials; ++i) in.removed[i] = r.removed[i];
  return in;
}

DrillInput SnapshotFeed::next(const haptics::HapticSnapshot& s) noexcept {
  DrillInput in;
  in.time_s = s.time_s;
  in.pedal = s.pedal != 0;
  in.contact = s.in_contact != 0;
  in.fault = s.fault != 0 || s.watchdog != 0;
  in.force_N = std::sqrt(s.force_dev_N[0] * s.force_dev_N[0] + s.force_dev_N[1] * s.force_dev_N[1] +
                         s.force_dev_N[2] * s.force_dev_N[2]);
  in.pulp_exposed = s.pulp_exposed != 0;
  const bool first = last_step_ == ~0ull;
  for (int i = 0; i < kSoundMaterials; ++i) {
    const double d = s.removed_mm3[i] - last_removed_[i];
    in.removed[i] = first || d < 0 ? 0.0 : d;  // a reset engine starts over
    last_removed_[i] = s.removed_mm3[i];
  }
  last_step_ = s.step;
  return in;
}

Result<std::vector<float>> render_session(const haptics::SessionLog& log, const DrillParams& params,
                                          std::uint64_t seed) {
  if (std::string e = params.validate(); !e.empty()) return Error{"drill sound: " + e};
  auto setup = haptics::parse_session_header(log.header_json);
  if (!setup) return Error{"session log header: " + setup.error()};
  const double rate = setup->engine.rate_hz;
  if (!(std::isfinite(rate) && rate > 0)) return Error{"session log header: engine rate_hz must be > 0"};
  const double fs = params.sample_rate_hz;
  std::vector<float> out;
  if (log.records.empty()) return out;
  const std::uint64_t last = log.records.back().step;
  const auto total = static_cast<std::size_t>(std::llround(static_cast<double>(last + 1) * fs / rate));
  out.assign(total, 0.0f);
  DrillSynth synth(params, seed);
  bool pulp = false;
  std::size_t pos = 0;
  for (std::size_t k = 0; k < log.records.size(); ++k) {
    const auto& r = log.records[k];
    // Dropped records leave gaps in `step`: the previous input holds over them.
    const auto start = static_cast<std::size_t>(std::llround(static_cast<double>(r.step) * fs / rate));
    if (start > pos && start <= total) {
      synth.render(out.data() + pos, start - pos);
      pos = start;
    }
    DrillInput in = input_from_record(r, rate);
    pulp = pulp || ((r.flags & haptics::kFlagPulpTouched) != 0 && r.pedal);
    in.pulp_exposed = pulp;
    synth.set_input(in);
  }
  if (total > pos) synth.render(out.data() + pos, total - pos);
  return out;
}

}  // namespace dentar::sound
