#include "gyrotc/algorithms/fit/cross_validation.hpp"

#include <algorithm>
#include <cmath>
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

CvScore cv_score(double dof, std::span<const double> loo) {
  if (loo.empty()) throw std::invalid_argument("cv score: no residuals");
  const auto n = static_cast<double>(loo.size());
  double mean = 0.0;
  for (double r : loo) mean += r * r;
  mean /= n;
  double var = 0.0;
  for (double r : loo) var += (r * r - mean) * (r * r - mean);
  const double sd = loo.size() > 1 ? std::sqrt(var / (n - 1.0)) : 0.0;
  return CvScore{dof, mean, sd / std::sqrt(n)};
}

std::size_t one_standard_error_choice(std::span<const CvScore> scores) {
  if (scores.empty()) throw std::invalid_argument("one-standard-error rule: no candidates");
  std::size_t best = 0;
  for (std::size_t i = 1; i < scores.size(); ++i) {
    if (scores[i].mse < scores[best].mse) best = i;
  }
  const double limit = scores[best].mse + scores[best].se;
  std::size_t chosen = best;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    if (!(scores[i].mse <= limit)) continue;
    if (scores[i].dof < scores[chosen].dof || (scores[i].dof == scores[chosen].dof && scores[i].mse < scores[chosen].mse)) {
      chosen = i;
    }
  }
  return chosen;
}

}  // namespace gyrotc::fit
