// Fixed-bin timing histogram for the haptic loop: 1 us bins up to 5 ms plus
// an overflow bin. record() is allocation-free and lock-free (single writer);
// percentiles are read after the run or from a copy.
#pragma once

#include <array>
#include <cstdint>

namespace dentar::haptics {

class TimingHistogram {
 public:
  static constexpr int kBins = 5000;  // 1 us each; the last bin collects overflow

  void record(double seconds) noexcept {
    const double us = seconds * 1e6;
    int b = us <= 0 ? 0 : static_cast<int>(us);
    if (!(b < kBins)) b = kBins - 1;  // also catches NaN
    ++bins_[static_cast<std::size_t>(b)];
    ++count_;
    if (seconds > max_s_) max_s_ = seconds;
  }
  std::uint64_t count() const { return count_; }
  double max_s() const { return max_s_; }
  // Upper edge of the bin holding quantile q in [0,1], in seconds (0 if empty).
  double percentile_s(double q) const {
    if (count_ == 0) return 0;
    const auto target = static_cast<std::uint64_t>(q * static_cast<double>(count_ - 1)) + 1;
    std::uint64_t acc = 0;
    for (int b = 0; b < kBins; ++b) {
      acc += bins_[static_cast<std::size_t>(b)];
      if (acc >= target) return (b + 1) * 1e-6;
    }
    return max_s_;
  }
  void clear() noexcept { *this = TimingHistogram{}; }

 private:
  std::array<std::uint64_t, kBins> bins_{};
  std::uint64_t count_ = 0;
  double max_s_ = 0;
};

}  // namespace dentar::haptics
