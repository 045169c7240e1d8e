#include "gyrotc/algorithms/stats/summary.hpp"

#include <cmath>

namespace gyrotc::stats {

double max_abs(std::span<const double> values) {
  double m = 0.0;
  for (double v : values) m = std::fmax(m, std::fabs(v));
  return m;
}

double rms(std::span<const double> values) {
  if (values.empty()) return 0.0;
  double s = 0.0;
  for (double v : values) s += v * v;
  return std::sqrt(s / static_cast<double>(values.size()));
}

double mean(std::span<const double> values) {
  if (values.empty()) return 0.0;
  double s = 0.0;
  for (double v : values) s += v;
  return s / static_cast<double>(values.size());
}

}  // namespace gyrotc::stats
