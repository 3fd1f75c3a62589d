#include "dentar/sound/player.h"

#include <algorithm>
#include <chrono>

namespace dentar::sound {

SoundPlayer::SoundPlayer(std::unique_ptr<AudioOutput> output, const DrillParams& params,
                         SnapshotSource source, std::uint64_t seed)
    : out_(std::move(output)), synth_(params, seed), source_(std::move(source)) {
  block_.assign(static_cast<std::size_t>(out_->options().period_frames), 0.0f);
}

SoundPlayer::~SoundPlayer() { stop(); }

int SoundPlayer::pump() {
  int n = 0;
  while (out_->free_blocks() > 0) {
    synth_.set_input(feed_.next(source_()));
    synth_.render(block_.data(), block_.size());
    if (muted_.load(std::memory_order_relaxed)) std::fill(block_.begin(), block_.end(), 0.0f);
    if (!out_->queue_block(block_.data())) break;
    ++n;
    blocks_.fetch_add(1, std::memory_order_relaxed);
  }
  return n;
}

void SoundPlayer::start() {
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] {
    const auto period = std::chrono::duration<double>(out_->options().period_frames /
                                                      static_cast<double>(out_->options().sample_rate_hz));
    const auto nap = std::chrono::duration_cast<std::chrono::microseconds>(period / 4);
    while (!stop_.load(std::memory_order_acquire)) {
      pump();
      std::this_thread::sleep_for(nap);
    }
  });
}

void SoundPlayer::stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

}  // namespace dentar::sound
