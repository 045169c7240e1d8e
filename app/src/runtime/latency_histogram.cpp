#include "gyrotc/app/runtime/latency_histogram.hpp"

#include <cmath>

namespace gyrotc::app {
namespace {

// Single writer: a relaxed load and store is enough (no read-modify-write).
template <typename U>
void bump(std::atomic<U>& value, U by) noexcept {
  value.store(static_cast<U>(value.load(std::memory_order_relaxed) + by), std::memory_order_relaxed);
}

}  // namespace

std::size_t LatencyHistogram::bin_of(std::uint64_t ns) noexcept {
  const std::uint64_t us = ns / 1000U;
  if (us < kFineBins) return static_cast<std::size_t>(us);
  const std::uint64_t coarse = (us - kFineBins) / 10U;
  if (coarse < kCoarseBins) return kFineBins + static_cast<std::size_t>(coarse);
  return kBins - 1;
}

double LatencyHistogram::upper_edge_s(std::size_t bin) noexcept {
  if (bin < kFineBins) return static_cast<double>(bin + 1) * 1e-6;
  return 1e-3 + static_cast<double>(bin - kFineBins + 1) * 10e-6;
}

void LatencyHistogram::add(double latency_s) noexcept {
  const double clamped_s = latency_s > 0.0 ? latency_s : 0.0;
  // Above ~584 years the conversion would overflow; clamp far below that.
  const auto ns = static_cast<std::uint64_t>(std::fmin(clamped_s, 1e6) * 1e9);
  bump(bins_[bin_of(ns)], std::uint32_t{1});
  bump(count_, std::uint64_t{1});
  bump(sum_ns_, ns);
  if (ns < min_ns_.load(std::memory_order_relaxed)) min_ns_.store(ns, std::memory_order_relaxed);
  if (ns > max_ns_.load(std::memory_order_relaxed)) max_ns_.store(ns, std::memory_order_relaxed);
}

LatencyHistogram::Summary LatencyHistogram::summary() const noexcept {
  Summary s;
  // Counts come from the bins, so the percentile is consistent with them
  // even while the writer is adding.
  std::array<std::uint32_t, kBins> counts;
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < kBins; ++i) {
    counts[i] = bins_[i].load(std::memory_order_relaxed);
    total += counts[i];
  }
  if (total == 0) return s;
  s.count = total;
  s.min_s = static_cast<double>(min_ns_.load(std::memory_order_relaxed)) * 1e-9;
  s.max_s = static_cast<double>(max_ns_.load(std::memory_order_relaxed)) * 1e-9;
  const std::uint64_t count = count_.load(std::memory_order_relaxed);
  s.avg_s = count == 0 ? 0.0
                       : static_cast<double>(sum_ns_.load(std::memory_order_relaxed)) * 1e-9 /
                             static_cast<double>(count);
  // Smallest bins with at least 50 % / 99 % of the samples at or below them.
  const std::uint64_t rank50 = (total * 50U + 99U) / 100U;
  const std::uint64_t rank99 = (total * 99U + 99U) / 100U;
  std::uint64_t seen = 0;
  bool have50 = false;
  for (std::size_t i = 0; i < kBins; ++i) {
    seen += counts[i];
    if (!have50 && seen >= rank50) {
      have50 = true;
      s.p50_s = i == kBins - 1 ? kOverflowS : upper_edge_s(i);
    }
    if (seen >= rank99) {
      s.p99_over = i == kBins - 1;
      s.p99_s = s.p99_over ? kOverflowS : upper_edge_s(i);
      break;
    }
  }
  return s;
}

}  // namespace gyrotc::app
