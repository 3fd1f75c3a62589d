// Contact-to-sound latency on OpenAL Soft's loopback device, and the haptic
// engine's step time with the sound on and off (docs/BENCHMARKS.md, issue 29).
//   ./build/sound/sound_latency_bench [events (100)] [engine rounds (3)]
//
// Latency: a 1 kHz publisher thread writes HapticSnapshots into the engine's own
// SeqLock type, as the engine does, with the pedal up; the bur touches (in_contact
// 0 -> 1) at random times (seeded) and the wall time of the publishing store is kept.
// A "sound card" thread is paced by absolute deadlines at the output period: each
// period it mixes one period through the loopback device (the samples leave now), then
// the SoundPlayer refills the queue from the latest snapshot. The probe tick's first
// non-zero sample in the output, at (mix time + offset / 48 kHz), minus the publish
// time is the latency. The output is silent between ticks, so onsets are exact.
//
// Engine: the real engine on its real-time thread (scripted access preparation,
// simulated hand), 4 s runs alternating sound off / on (the SoundPlayer reading
// Engine::snapshot() beside a paced loopback card); step compute time percentiles
// from the engine's own histogram.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>
#include <vector>

#include "dentar/haptics/engine.h"
#include "dentar/haptics/scripts.h"
#include "dentar/haptics/seqlock.h"
#include "dentar/haptics/simulated_device.h"
#include "dentar/sound/player.h"
#include "dentar/volume/procedural_tooth.h"

using namespace dentar;
using Clock = std::chrono::steady_clock;

namespace {

double pct(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
}

// A card thread: mixes `period` frames every period (absolute deadlines), then refills.
template <typename OnMix>
void card_loop(sound::SoundPlayer& player, int period, const std::atomic<bool>& stop, OnMix on_mix) {
  std::vector<float> stereo(static_cast<std::size_t>(2 * period));
  const auto dt = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period / 48000.0));
  auto next = Clock::now();
  player.pump();
  while (!stop.load()) {
    next += dt;
    std::this_thread::sleep_until(next);
    const auto t_mix = Clock::now();
    player.output().render(stereo.data(), period);
    on_mix(t_mix, stereo);
    player.pump();
  }
}

void latency(int period, int queue, int events) {
  haptics::SeqLock<haptics::HapticSnapshot> snap;
  sound::OutputOptions oo;
  oo.period_frames = period;
  oo.queue_buffers = queue;
  auto out = sound::AudioOutput::open_loopback(oo);
  if (!out) {
    std::printf("loopback: %s\n", out.error().c_str());
    return;
  }
  sound::SoundPlayer player(std::move(out).value(), sound::default_drill_params(), [&snap] { return snap.load(); });
  std::vector<Clock::time_point> t_event(static_cast<std::size_t>(events));
  std::vector<double> lat_ms;
  std::atomic<bool> stop{false};
  std::atomic<int> published{0};
  std::thread publisher([&] {
    std::mt19937 rng(29);
    std::uniform_int_distribution<int> gap(150, 250);
    haptics::HapticSnapshot s;
    auto next = Clock::now();
    int until_touch = gap(rng), touching = 0, ev = 0;
    for (std::uint64_t step = 0; ev < events || touching > 0; ++step) {
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
      s.step = step;
      s.time_s = static_cast<double>(step) * 1e-3;
      if (touching > 0 && --touching == 0) s.in_contact = 0;
      if (touching == 0 && --until_touch <= 0 && ev < events) {
        s.in_contact = 1;
        s.force_dev_N[1] = 0.5;
        touching = 40;
        until_touch = gap(rng);
        t_event[static_cast<std::size_t>(ev)] = Clock::now();
        snap.store(s);
        published.store(++ev);
        continue;
      }
      snap.store(s);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    stop.store(true);
  });
  int heard = 0, missed = 0;
  bool silent_before = true;
  std::size_t silent_run = 0;
  card_loop(player, period, stop, [&](Clock::time_point t_mix, const std::vector<float>& st) {
    for (int i = 0; i < period; ++i) {
      const bool nz = st[static_cast<std::size_t>(2 * i)] != 0.0f;
      if (nz && silent_before && heard < published.load()) {
        const auto t_out = t_mix + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(i / 48000.0));
        // The tick belongs to the latest event published before it (an event whose contact
        // the player never saw, e.g. the card thread descheduled for longer than the 40 ms
        // touch, is counted as missed, not paired with a later tick).
        int e = published.load() - 1;
        while (e > heard && t_event[static_cast<std::size_t>(e)] > t_out) --e;
        missed += e - heard;
        lat_ms.push_back(std::chrono::duration<double, std::milli>(t_out - t_event[static_cast<std::size_t>(e)]).count());
        heard = e + 1;
        silent_before = false;
        silent_run = 0;
      }
      if (!nz) {
        if (++silent_run > 2400) silent_before = true;  // 50 ms of silence between ticks
      } else {
        silent_run = 0;
      }
    }
  });
  publisher.join();
  std::printf("latency period %d frames (%.2f ms), %d blocks queued: %d/%d events heard (%d missed); median %.2f ms, p99 %.2f ms, max %.2f ms; underruns %zu\n",
              period, period / 48.0, queue, static_cast<int>(lat_ms.size()), events, missed, pct(lat_ms, 0.5), pct(lat_ms, 0.99), pct(lat_ms, 1.0),
              player.output().underruns());
}

void engine_runs(int rounds) {
  const volume::VoxelVolume base = std::move(volume::make_molar({})).value();
  auto bur = std::move(volume::sample_bur(volume::BurParams::capsule(0.5, 3.0), 10000)).value();
  const haptics::Station st = haptics::default_station();
  for (int r = 0; r < 2 * rounds; ++r) {
    const bool sound_on = r % 2 == 1;
    volume::VoxelVolume tooth = base.clone();
    haptics::HandParams hand;
    hand.stiffness_N_per_m = haptics::kFingerRestStiffness_N_per_m;
    auto dev = std::move(haptics::SimulatedDevice::create(
                             haptics::to_hand_script(haptics::tip_script("access", 2.5, 4.0), st), {}, hand))
                   .value();
    haptics::EngineConfig cfg;
    cfg.T_tooth_dev = st.T_tooth_dev;
    cfg.T_sty_tip = st.T_sty_tip;
    auto engine = std::move(haptics::Engine::create(cfg, *dev, tooth, bur)).value();
    std::unique_ptr<sound::SoundPlayer> player;
    std::atomic<bool> stop{false};
    std::thread card;
    if (sound_on) {
      auto out = std::move(sound::AudioOutput::open_loopback({})).value();
      player = std::make_unique<sound::SoundPlayer>(std::move(out), sound::default_drill_params(),
                                                    [&engine] { return engine->snapshot(); });
      card = std::thread([&] { card_loop(*player, player->output().options().period_frames, stop, [](Clock::time_point, const std::vector<float>&) {}); });
    }
    if (auto s = engine->start(); !s) {
      std::printf("engine: %s\n", s.error().c_str());
      return;
    }
    std::this_thread::sleep_for(std::chrono::seconds(4));
    engine->stop();
    stop.store(true);
    if (card.joinable()) card.join();
    const auto s = engine->stats();
    std::printf("engine sound %-3s: %llu steps, compute p50 %.0f us, p99 %.0f us, p99.9 %.0f us, max %.0f us; "
                "missed deadlines %llu; realtime %s; sound blocks %llu\n",
                sound_on ? "on" : "off", static_cast<unsigned long long>(s.steps), s.compute.percentile_s(0.5) * 1e6,
                s.compute.percentile_s(0.99) * 1e6, s.compute.percentile_s(0.999) * 1e6, s.compute.max_s() * 1e6,
                static_cast<unsigned long long>(s.missed_deadlines), s.realtime_granted ? "yes" : "no",
                static_cast<unsigned long long>(player ? player->blocks() : 0));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int events = argc > 1 ? std::max(10, std::atoi(argv[1])) : 100;
  const int rounds = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
  latency(256, 3, events);
  latency(128, 3, events);
  latency(128, 2, events);
  engine_runs(rounds);
  return 0;
}
