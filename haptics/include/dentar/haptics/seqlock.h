// SeqLock<T>: single writer, many readers; the writer never waits. Readers
// retry while a write is in progress. T must be trivially copyable; its bytes
// are stored in relaxed atomic words so concurrent access is race-free (and
// clean under ThreadSanitizer).
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace dentar::haptics {

template <typename T>
class SeqLock {
  static_assert(std::is_trivially_copyable_v<T>, "SeqLock needs a trivially copyable T");
  static constexpr std::size_t kWords = (sizeof(T) + 7) / 8;

 public:
  SeqLock() {
    T zero{};
    store(zero);
  }

  // Writer thread only (the haptic thread). Wait-free.
  void store(const T& v) noexcept {
    std::uint64_t buf[kWords] = {};
    std::memcpy(buf, &v, sizeof(T));
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);  // odd: write in progress
    // Release stores keep the odd sequence number ahead of every data word
    // (no fences: ThreadSanitizer does not model them; on x86 all of this is
    // plain moves).
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(buf[i], std::memory_order_release);
    seq_.store(s + 2, std::memory_order_release);
  }

  // Any thread. Retries while the writer is mid-store (a few ns at 1 kHz).
  T load() const noexcept {
    std::uint64_t buf[kWords];
    for (;;) {
      const std::uint64_t s0 = seq_.load(std::memory_order_acquire);
      if (s0 & 1) continue;
      // Acquire loads keep the re-read of the sequence after the data.
      for (std::size_t i = 0; i < kWords; ++i) buf[i] = words_[i].load(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s0) break;
    }
    T v;
    std::memcpy(&v, buf, sizeof(T));
    return v;
  }

  std::uint64_t version() const noexcept { return seq_.load(std::memory_order_acquire) / 2; }

 private:
  std::atomic<std::uint64_t> seq_{0};
  std::atomic<std::uint64_t> words_[kWords];
};

}  // namespace dentar::haptics
