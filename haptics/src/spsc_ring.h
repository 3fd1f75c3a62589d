// Bounded single-producer/single-consumer ring of trivially copyable values.
//
// The producer (the 1 kHz haptic thread) never allocates, locks, makes a
// syscall or waits: try_push() either copies into a free slot or returns
// false. Storage is allocated once in the constructor. Indices count pushes
// and pops since construction (64-bit: they never wrap in practice) and are
// masked into the power-of-two storage.
#pragma once

#include <atomic>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <type_traits>

namespace dentar::haptics::detail {

template <typename T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "slots are copied without constructors");

 public:
  // capacity: a power of two >= 2 (validated by the caller).
  explicit SpscRing(std::size_t capacity)
      : mask_(capacity - 1), slots_(std::make_unique<T[]>(capacity)) {
    assert(capacity >= 2 && (capacity & (capacity - 1)) == 0 &&
           "dentar::haptics::detail::SpscRing: capacity must be a power of two >= 2");
  }

  std::size_t capacity() const { return mask_ + 1; }

  // Producer thread only.
  bool try_push(const T& v) noexcept {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      // Looks full: refresh the consumer's position (acquire: its reads of
      // the slots we are about to overwrite are finished).
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    slots_[head & mask_] = v;
    head_.store(head + 1, std::memory_order_release);  // publishes the slot
    return true;
  }

  // Consumer thread only: calls f(const T* first, std::size_t n) for up to
  // two contiguous spans holding at most `max` of the oldest values, then
  // frees those slots. Returns the number consumed.
  template <typename F>
  std::size_t consume(std::size_t max, F&& f) {
    const std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    std::size_t n = static_cast<std::size_t>(head - tail);
    if (n > max) n = max;
    if (n == 0) return 0;
    const std::size_t start = static_cast<std::size_t>(tail & mask_);
    const std::size_t first = n < capacity() - start ? n : capacity() - start;
    f(&slots_[start], first);
    if (n > first) f(&slots_[0], n - first);
    tail_.store(tail + n, std::memory_order_release);  // slots may be reused now
    return n;
  }

  // Any thread: a snapshot that may be stale by the time it is used.
  std::size_t size_approx() const {
    const std::uint64_t tail = tail_.load(std::memory_order_acquire);
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    return head >= tail ? static_cast<std::size_t>(head - tail) : 0;
  }

 private:
  // Separate cache lines so producer and consumer do not false-share.
  static constexpr std::size_t kLine = 64;
  alignas(kLine) std::atomic<std::uint64_t> head_{0};  // written by the producer
  std::uint64_t tail_cache_ = 0;                       // producer's last view of tail_
  alignas(kLine) std::atomic<std::uint64_t> tail_{0};  // written by the consumer
  alignas(kLine) const std::size_t mask_;
  std::unique_ptr<T[]> slots_;
};

}  // namespace dentar::haptics::detail
