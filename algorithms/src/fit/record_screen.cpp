#include "gyrotc/algorithms/fit/record_screen.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "gyrotc/algorithms/text/printf_string.hpp"

namespace gyrotc::fit {
namespace {

struct Bin {
  std::size_t count = 0;
  double abs_rate_sum_c_per_min = 0.0;
  double rate_sum_c_per_min = 0.0;
};

}  // namespace

std::vector<double> rates_c_per_min(std::span<const double> t, std::span<const double> temp, double window_s) {
  const std::size_t n = t.size();
  std::vector<double> rate(n, 0.0);
  std::size_t lo = 0;
  std::size_t hi = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (t[i] - t[lo] > 0.5 * window_s) ++lo;
    while (hi + 1 < n && t[hi + 1] - t[i] <= 0.5 * window_s) ++hi;
    const double dt = t[hi] - t[lo];
    rate[i] = dt > 0.0 ? 60.0 * (temp[hi] - temp[lo]) / dt : 0.0;
  }
  return rate;
}

const char* screen_check_name(ScreenCheck check) {
  switch (check) {
    case ScreenCheck::held: return "held";
    case ScreenCheck::span: return "span";
    case ScreenCheck::uneven: return "uneven";
    case ScreenCheck::unsettled: return "unsettled";
  }
  return "?";
}

std::vector<ScreenFinding> screen_calibration_record(const RecordSamples& record, const ScreenLimits& limits) {
  const std::size_t n = record.sensor_c.size();
  if (record.time_s.size() != n) throw std::invalid_argument("record screen: time_s and sensor_c differ in length");
  if (!(limits.bin_width_c > 0.0)) throw std::invalid_argument("record screen: bin width must be positive");
  std::vector<ScreenFinding> findings;
  if (n == 0) {
    findings.push_back({ScreenCheck::span, "the record has no samples"});
    return findings;
  }

  // held: the TEC on and the casing within the band of one setpoint.
  if (record.setpoint_c && record.tec_on && record.setpoint_c->size() == n && record.tec_on->size() == n) {
    std::map<double, std::size_t> held_at;  // setpoint -> held samples
    for (std::size_t i = 0; i < n; ++i) {
      const double sp = (*record.setpoint_c)[i];
      if ((*record.tec_on)[i] && std::fabs(record.sensor_c[i] - sp) <= limits.hold_band_c) ++held_at[sp];
    }
    const auto most = std::max_element(held_at.begin(), held_at.end(),
                                       [](const auto& a, const auto& b) { return a.second < b.second; });
    if (most != held_at.end()) {
      const double fraction = static_cast<double>(most->second) / static_cast<double>(n);
      if (fraction > limits.max_held_fraction) {
        findings.push_back({ScreenCheck::held,
                            text::printf_string(
                                "the TEC held the casing within %g C of the setpoint %g C for %.0f %% of the record: a "
                                "closed-loop run, whose other temperatures are passed in a hurry on the way there",
                                limits.hold_band_c, most->first, 100.0 * fraction)});
      }
    }
  }

  const std::vector<double> rate = rates_c_per_min(record.time_s, record.sensor_c, limits.rate_window_s);
  std::map<long long, Bin> bins;  // keyed as `fit` bins: floor(T / width)
  for (std::size_t i = 0; i < n; ++i) {
    Bin& b = bins[static_cast<long long>(std::floor(record.sensor_c[i] / limits.bin_width_c))];
    ++b.count;
    b.abs_rate_sum_c_per_min += std::fabs(rate[i]);
    b.rate_sum_c_per_min += rate[i];
  }

  const auto [lo, hi] = std::minmax_element(record.sensor_c.begin(), record.sensor_c.end());
  if (*hi - *lo < limits.min_span_c || bins.size() < limits.min_bins) {
    findings.push_back(
        {ScreenCheck::span, text::printf_string("the casing spans %.1f .. %.1f C in %g bins of %g C", *lo, *hi,
                                                static_cast<double>(bins.size()), limits.bin_width_c) +
                                text::printf_string("; the model needs at least %g C and %g bins", limits.min_span_c,
                                                    static_cast<double>(limits.min_bins))});
  }

  std::vector<std::size_t> counts;
  for (const auto& [key, b] : bins) counts.push_back(b.count);
  std::nth_element(counts.begin(), counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2), counts.end());
  const double median = static_cast<double>(counts[counts.size() / 2]);
  const auto fullest = std::max_element(bins.begin(), bins.end(),
                                        [](const auto& a, const auto& b) { return a.second.count < b.second.count; });
  if (static_cast<double>(fullest->second.count) > limits.max_bin_ratio * median) {
    findings.push_back(
        {ScreenCheck::uneven,
         text::printf_string(
             "the %g C bin holds %g samples, %.0f times the median bin's %g: the points' noise differs that much",
             static_cast<double>(fullest->first) * limits.bin_width_c, static_cast<double>(fullest->second.count),
             static_cast<double>(fullest->second.count) / median, median)});
  }

  // A bin is unsettled when its samples moved on average one way faster than
  // max_rate (the lag does not cancel), or crossed it faster than
  // max_crossing_rate either way.
  std::size_t unsettled = 0;
  double worst_excess = 0.0;
  double worst_rate = 0.0;
  double worst_bin_c = 0.0;
  for (const auto& [key, b] : bins) {
    const double count = static_cast<double>(b.count);
    const double net_rate = std::fabs(b.rate_sum_c_per_min) / count;
    const double crossing_rate = b.abs_rate_sum_c_per_min / count;
    const double excess = std::max(net_rate / limits.max_rate_c_per_min,
                                   crossing_rate / limits.max_crossing_rate_c_per_min);
    if (excess > 1.0) ++unsettled;
    if (excess > worst_excess) {
      worst_excess = excess;
      worst_rate = net_rate / limits.max_rate_c_per_min >= crossing_rate / limits.max_crossing_rate_c_per_min
                       ? net_rate
                       : crossing_rate;
      worst_bin_c = static_cast<double>(key) * limits.bin_width_c;
    }
  }
  if (unsettled > 0) {
    findings.push_back(
        {ScreenCheck::unsettled,
         text::printf_string("in %g of %g bins the casing moved faster than %g C/min", static_cast<double>(unsettled),
                             static_cast<double>(bins.size()), limits.max_rate_c_per_min) +
             text::printf_string(
                 " (%.2f C/min at %g C; a bin crossed both ways at one rate may take up to %g C/min): the die "
                 "lags the sensor, so those bins' bias belongs to another temperature",
                 worst_rate, worst_bin_c, limits.max_crossing_rate_c_per_min)});
  }
  return findings;
}

}  // namespace gyrotc::fit
