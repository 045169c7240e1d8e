#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

namespace gyrotc::app {

// The real-time loop's wake-up latency (time from the DRDY edge or the
// intended wake-up to the loop running) in a fixed histogram: adding a value
// is a few integer operations, no allocation, and another thread can
// summarise it at any time (approximately while the loop runs).
//
// Bins: 1 us wide below 1 ms, 10 us wide from 1 ms to 10 ms, one overflow bin
// above. The p50 and p99 are the upper edges of its bin; min, max and mean are exact.
class LatencyHistogram {
 public:
  static constexpr std::size_t kFineBins = 1000;    // [0, 1 ms) in 1 us
  static constexpr std::size_t kCoarseBins = 900;   // [1 ms, 10 ms) in 10 us
  static constexpr std::size_t kBins = kFineBins + kCoarseBins + 1;  // + overflow
  static constexpr double kOverflowS = 10e-3;

  struct Summary {
    std::uint64_t count = 0;
    double min_s = 0.0;
    double avg_s = 0.0;
    double p50_s = 0.0;      // upper edge of the bin holding the median
    double p99_s = 0.0;      // upper edge of the bin holding the 99th percentile
    bool p99_over = false;   // the 99th percentile is beyond kOverflowS
    double max_s = 0.0;
  };

  // Writer only (the real-time thread). Negative values count as 0.
  void add(double latency_s) noexcept;
  // Any thread.
  Summary summary() const noexcept;

 private:
  static std::size_t bin_of(std::uint64_t ns) noexcept;
  static double upper_edge_s(std::size_t bin) noexcept;

  std::array<std::atomic<std::uint32_t>, kBins> bins_{};
  std::atomic<std::uint64_t> count_{0};
  std::atomic<std::uint64_t> sum_ns_{0};
  std::atomic<std::uint64_t> min_ns_{UINT64_MAX};
  std::atomic<std::uint64_t> max_ns_{0};
};

}  // namespace gyrotc::app
