// CPU cost of the drill's sound per second of audio at 48 kHz (docs/BENCHMARKS.md, issue 29).
//   ./build/sound/sound_synth_bench
// BM_SynthDrilling/<material>: the synth alone, drilling at 1.5 N, 256-sample blocks
//   with a new input per block (what the live audio thread does).
// BM_SynthIdle: free-running, no contact.
// BM_LoopbackMix: OpenAL Soft queueing and mixing one second (the loopback device
//   stands in for the card's mixer thread).
// counter cpu_pct_of_core = CPU seconds (this thread) per second of audio x 100.
#include <benchmark/benchmark.h>

#include <vector>

#include "dentar/sound/audio_output.h"
#include "dentar/sound/drill_synth.h"

namespace dentar::sound {
namespace {

constexpr int kBlock = 128;  // the live default (OutputOptions::period_frames)
constexpr int kFs = 48000;

void run_second(DrillSynth& s, std::vector<float>& buf, int material, double force, bool contact) {
  for (int at = 0; at + kBlock <= kFs; at += kBlock) {
    DrillInput in;
    in.time_s = at / double(kFs);
    in.pedal = true;
    in.contact = contact;
    in.force_N = force;
    if (material > 0) in.removed[material] = 1.0;
    s.set_input(in);
    s.render(buf.data() + at, kBlock);
  }
}

void BM_SynthDrilling(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0));
  DrillSynth s(default_drill_params());
  std::vector<float> buf(kFs);
  run_second(s, buf, 0, 0, false);  // spun up
  for (auto _ : state) {
    run_second(s, buf, m, 1.5, true);
    benchmark::DoNotOptimize(buf.data());
  }
  state.counters["cpu_pct_of_core"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / 100.0, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetLabel(default_drill_params().materials[static_cast<std::size_t>(m)].name);
}
BENCHMARK(BM_SynthDrilling)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);

void BM_SynthIdle(benchmark::State& state) {
  DrillSynth s(default_drill_params());
  std::vector<float> buf(kFs);
  for (auto _ : state) {
    run_second(s, buf, 0, 0, false);
    benchmark::DoNotOptimize(buf.data());
  }
  state.counters["cpu_pct_of_core"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / 100.0, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SynthIdle)->Unit(benchmark::kMillisecond);

void BM_LoopbackMix(benchmark::State& state) {
  auto out = AudioOutput::open_loopback({});
  if (!out) {
    state.SkipWithError(out.error().c_str());
    return;
  }
  AudioOutput& a = **out;
  std::vector<float> block(kBlock, 0.1f), stereo(2 * kBlock);
  for (auto _ : state) {
    for (int at = 0; at + kBlock <= kFs; at += kBlock) {
      while (a.free_blocks() > 0) (void)a.queue_block(block.data());
      a.render(stereo.data(), kBlock);
    }
    benchmark::DoNotOptimize(stereo.data());
  }
  state.counters["cpu_pct_of_core"] = benchmark::Counter(
      static_cast<double>(state.iterations()) / 100.0, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_LoopbackMix)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace dentar::sound

BENCHMARK_MAIN();
