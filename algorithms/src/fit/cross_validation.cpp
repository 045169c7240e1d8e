#include "gyrotc/algorithms/fit/cross_validation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

std::vector<std::vector<std::size_t>> held_out_blocks(std::span<const double> temp_c, double block_c) {
  if (!(block_c >= 0.0) || !std::isfinite(block_c)) throw std::invalid_argument("held-out block: width must be >= 0");
  std::vector<std::vector<std::size_t>> blocks(temp_c.size());
  for (std::size_t i = 0; i < temp_c.size(); ++i) {
    blocks[i].push_back(i);
    if (block_c == 0.0) continue;
    for (std::size_t j = 0; j < temp_c.size(); ++j) {
      if (j != i && std::abs(temp_c[j] - temp_c[i]) <= block_c) blocks[i].push_back(j);
    }
  }
  return blocks;
}

std::vector<double> block_residuals(std::span<const double> temp_c, std::span<const double> value,
                                    const Fitter& fitter, double block_c, std::size_t min_kept) {
  if (block_c == 0.0) return loo_residuals(temp_c, value, fitter);
  const std::size_t n = temp_c.size();
  if (n < 2 || value.size() != n) throw std::invalid_argument("held-out blocks: need at least 2 points");
  const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
  const auto blocks = held_out_blocks(temp_c, block_c);
  std::vector<double> out(n);
  std::vector<char> left(n);
  std::vector<double> t;
  std::vector<double> v;
  for (std::size_t k = 0; k < n; ++k) {
    const bool whole = n - blocks[k].size() >= min_kept;
    std::fill(left.begin(), left.end(), 0);
    if (whole) {
      for (std::size_t j : blocks[k]) left[j] = 1;
    } else {
      left[k] = 1;
    }
    t.clear();
    v.clear();
    for (std::size_t i = 0; i < n; ++i) {
      if (left[i]) continue;
      t.push_back(temp_c[i]);
      v.push_back(value[i]);
    }
    out[k] = value[k] - fitter(t, v, *lo, *hi).bias_mv(temp_c[k]);
  }
  return out;
}

std::vector<double> linear_smoother_block_residuals(const Eigen::VectorXd& residual,
                                                    const std::vector<std::vector<std::size_t>>& blocks,
                                                    const std::function<double(std::size_t, std::size_t)>& hat) {
  std::vector<double> out(blocks.size());
  Eigen::MatrixXd a;
  Eigen::VectorXd eb;
  Eigen::VectorXd rb;
  // I - H_BB is symmetric and positive semi-definite (H's eigenvalues lie in
  // [0, 1], and so do its principal submatrix's): a pivoted LDL' solves it in
  // half a full-pivot LU's time. One object for every block keeps its storage
  // while the block's size repeats.
  Eigen::LDLT<Eigen::MatrixXd> ldlt;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const auto& b = blocks[i];
    const double loo = residual(static_cast<Eigen::Index>(i)) / std::max(1.0 - hat(i, i), 1e-12);
    const auto m = static_cast<Eigen::Index>(b.size());
    if (m == 1) {
      out[i] = loo;
      continue;
    }
    a.resize(m, m);
    eb.resize(m);
    for (Eigen::Index r = 0; r < m; ++r) {
      const std::size_t br = b[static_cast<std::size_t>(r)];
      eb(r) = residual(static_cast<Eigen::Index>(br));
      for (Eigen::Index c = r; c < m; ++c) {
        const double h = hat(br, b[static_cast<std::size_t>(c)]);
        a(r, c) = (r == c ? 1.0 : 0.0) - h;
        a(c, r) = a(r, c);
      }
    }
    ldlt.compute(a);
    // A block the fit cannot do without (I - H_BB singular: the rest does
    // not determine the model) predicts its point as leave-one-out does. The
    // rank test is FullPivLU's: a pivot within m * epsilon of the largest.
    const Eigen::VectorXd& d = ldlt.vectorD();
    const double d_max = d.cwiseAbs().maxCoeff();
    const bool invertible =
        ldlt.info() == Eigen::Success && d_max > 0.0 &&
        d.cwiseAbs().minCoeff() > static_cast<double>(m) * std::numeric_limits<double>::epsilon() * d_max;
    if (!invertible) {
      out[i] = loo;
      continue;
    }
    rb = ldlt.solve(eb);
    out[i] = rb(0);
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
