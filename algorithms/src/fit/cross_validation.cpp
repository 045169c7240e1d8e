#include "gyrotc/algorithms/fit/cross_validation.hpp"

#include <algorithm>
#include <stdexcept>

#include "gyrotc/algorithms/stats/summary.hpp"

namespace gyrotc::fit {

std::vector<double> loo_residuals(std::span<const double> temp_c, std::span<const double> value,
                                  const Fitter& fitter) {
  const std::size_t n = temp_c.size();
  if (n < 2 || value.size() != n) throw std::invalid_argument("leave-one-out: need at least 2 points");
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  std::vector<double> t;
  std::vector<double> v;
  t.reserve(n - 1);
  v.reserve(n - 1);
  std::vector<double> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    t.clear();
    v.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (i == k) continue;
      t.push_back(temp_c[i]);
      v.push_back(value[i]);
    }
    const BiasModel model = fitter(t, v, *lo, *hi);
    out[k] = value[k] - model.bias_mv(temp_c[k]);
  }
  return out;
}

std::vector<double> residuals(const BiasModel& model, std::span<const double> temp_c,
                              std::span<const double> value) {
  std::vector<double> out(temp_c.size());
  for (std::size_t i = 0; i < temp_c.size(); ++i) out[i] = value[i] - model.bias_mv(temp_c[i]);
  return out;
}

FitErrors fit_errors(std::span<const double> in_sample_residuals, std::span<const double> loo) {
  return FitErrors{stats::max_abs(in_sample_residuals), stats::rms(in_sample_residuals),
                   stats::max_abs(loo), stats::rms(loo)};
}

}  // namespace gyrotc::fit
