// The live sound: an audio thread that keeps an AudioOutput's queue full with
// the drill, reading the haptic engine's snapshot (a seqlock load, the same
// lock-free read the display does) once per block. The engine's 1 kHz thread
// is never touched: nothing is pushed to it, nothing waits for it.
//
// Latency from a change in the snapshot to its first sample at the output:
// up to one block (the poll) + the blocks queued ahead + the device's period
// (docs/sound.md, docs/BENCHMARKS.md "Issue 29").
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "dentar/haptics/engine.h"
#include "dentar/sound/audio_output.h"
#include "dentar/sound/drill_synth.h"
#include "dentar/sound/feed.h"

namespace dentar::sound {

class SoundPlayer {
 public:
  // The snapshot source is called on the audio thread (or by pump()); it must
  // be lock-free, e.g. [&engine] { return engine.snapshot(); }.
  using SnapshotSource = std::function<haptics::HapticSnapshot()>;
  SoundPlayer(std::unique_ptr<AudioOutput> output, const DrillParams& params, SnapshotSource source,
              std::uint64_t seed = 1);
  ~SoundPlayer();  // stops the thread
  SoundPlayer(const SoundPlayer&) = delete;
  SoundPlayer& operator=(const SoundPlayer&) = delete;

  // Real time: a thread refills the queue every quarter period. A loopback
  // output is mixed by whoever calls output().render() (tests, benchmarks).
  void start();
  void stop();
  // One refill on the calling thread: fills every free block; returns how many.
  int pump();
  void set_muted(bool m) { muted_.store(m, std::memory_order_relaxed); }
  AudioOutput& output() { return *out_; }
  const DrillSynth& synth() const { return synth_; }
  std::uint64_t blocks() const { return blocks_.load(std::memory_order_relaxed); }

 private:
  std::unique_ptr<AudioOutput> out_;
  DrillSynth synth_;
  SnapshotSource source_;
  SnapshotFeed feed_;
  std::vector<float> block_;
  std::atomic<bool> stop_{false}, muted_{false};
  std::atomic<std::uint64_t> blocks_{0};
  std::thread thread_;
};

}  // namespace dentar::sound
