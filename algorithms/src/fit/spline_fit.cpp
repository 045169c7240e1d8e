#include "gyrotc/algorithms/fit/spline_fit.hpp"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "gyrotc/algorithms/fit/cross_validation.hpp"

namespace gyrotc::fit {

namespace {

struct Sorted {
  std::vector<std::size_t> order;  // input index of each sorted point
  std::vector<double> x;
  std::vector<double> y;
  double lo = 0.0;
  double hi = 0.0;
};

// The points in ascending temperature, checked, and the model's range.
Sorted sorted_points(std::span<const double> temp_c, std::span<const double> value, std::size_t min_points,
                     const char* what, double t_min_c, double t_max_c) {
  if (temp_c.size() != value.size()) throw std::invalid_argument(std::string(what) + ": temperature and value counts differ");
  if (temp_c.size() < min_points) {
    throw std::invalid_argument(std::string(what) + ": needs at least " + std::to_string(min_points) +
                                " points, got " + std::to_string(temp_c.size()));
  }
  std::vector<std::size_t> idx(temp_c.size());
  std::iota(idx.begin(), idx.end(), 0);
  for (std::size_t i : idx) {
    if (!std::isfinite(temp_c[i]) || !std::isfinite(value[i])) {
      throw std::invalid_argument(std::string(what) + ": non-finite value at point " + std::to_string(i));
    }
  }
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return temp_c[a] < temp_c[b]; });
  Sorted s;
  for (std::size_t i : idx) {
    if (!s.x.empty() && !(temp_c[i] > s.x.back())) {
      throw std::invalid_argument(std::string(what) + ": temperature " + std::to_string(temp_c[i]) +
                                  " C appears twice (average repeated points into one)");
    }
    s.order.push_back(i);
    s.x.push_back(temp_c[i]);
    s.y.push_back(value[i]);
  }
  s.lo = t_min_c < t_max_c ? std::min(t_min_c, s.x.front()) : s.x.front();
  s.hi = t_min_c < t_max_c ? std::max(t_max_c, s.x.back()) : s.x.back();
  return s;
}

Spline make_spline(Sorted&& s, std::vector<double> second_derivatives) {
  Spline sp;
  sp.knots_c = std::move(s.x);
  sp.values_mv = std::move(s.y);
  sp.second_derivatives = std::move(second_derivatives);
  sp.t_min_c = s.lo;
  sp.t_max_c = s.hi;
  return sp;
}

// A natural spline continues as a straight line beyond its end knots: a knot
// at each range end outside the data, on the end tangent, with m = 0.
void extend_linearly(Sorted& s, std::vector<double>& m) {
  const std::size_t n = s.x.size();
  const double h0 = s.x[1] - s.x[0];
  const double slope0 = (s.y[1] - s.y[0]) / h0 - h0 * m[1] / 6.0;  // m[0] = 0
  const double h1 = s.x[n - 1] - s.x[n - 2];
  const double slope1 = (s.y[n - 1] - s.y[n - 2]) / h1 + h1 * m[n - 2] / 6.0;  // m[n-1] = 0
  if (s.hi > s.x.back()) {
    s.y.push_back(s.y.back() + slope1 * (s.hi - s.x.back()));
    s.x.push_back(s.hi);
    m.push_back(0.0);
  }
  if (s.lo < s.x.front()) {
    s.y.insert(s.y.begin(), s.y.front() - slope0 * (s.x.front() - s.lo));
    s.x.insert(s.x.begin(), s.lo);
    m.insert(m.begin(), 0.0);
  }
}

// The not-a-knot interpolant's second derivatives as a linear map of the
// values (n >= 4): S m = 6 D y, with rows 1..n-2 the continuity of the first
// derivative at the interior knots and rows 0 and n-1 the continuity of the
// third derivative at knots 1 and n-2 (D is zero there).
class NotAKnot {
 public:
  explicit NotAKnot(const std::vector<double>& x) : n_(x.size()), h_(x.size() - 1) {
    for (std::size_t i = 0; i + 1 < n_; ++i) h_[i] = x[i + 1] - x[i];
    using Triplet = Eigen::Triplet<double>;
    std::vector<Triplet> entries;
    entries.emplace_back(0, 0, h_[1]);
    entries.emplace_back(0, 1, -(h_[0] + h_[1]));
    entries.emplace_back(0, 2, h_[0]);
    for (std::size_t i = 1; i + 1 < n_; ++i) {
      entries.emplace_back(at(i), at(i - 1), h_[i - 1]);
      entries.emplace_back(at(i), at(i), 2.0 * (h_[i - 1] + h_[i]));
      entries.emplace_back(at(i), at(i + 1), h_[i]);
    }
    entries.emplace_back(at(n_ - 1), at(n_ - 3), h_[n_ - 2]);
    entries.emplace_back(at(n_ - 1), at(n_ - 2), -(h_[n_ - 3] + h_[n_ - 2]));
    entries.emplace_back(at(n_ - 1), at(n_ - 1), h_[n_ - 3]);
    Eigen::SparseMatrix<double> a(at(n_), at(n_));
    a.setFromTriplets(entries.begin(), entries.end());
    lu_.compute(a);
    if (lu_.info() != Eigen::Success) throw std::invalid_argument("spline: the not-a-knot system is singular");
  }

  // 6 D: the right-hand side as a matrix of the values.
  Eigen::MatrixXd rhs_operator() const {
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(at(n_), at(n_));
    for (std::size_t i = 1; i + 1 < n_; ++i) {
      d(at(i), at(i - 1)) = 6.0 / h_[i - 1];
      d(at(i), at(i)) = -6.0 / h_[i - 1] - 6.0 / h_[i];
      d(at(i), at(i + 1)) = 6.0 / h_[i];
    }
    return d;
  }

  template <typename Rhs>
  Eigen::MatrixXd solve(const Rhs& rhs) {
    return lu_.solve(rhs);
  }

  const std::vector<double>& intervals() const { return h_; }

 private:
  static Eigen::Index at(std::size_t i) { return static_cast<Eigen::Index>(i); }

  std::size_t n_;
  std::vector<double> h_;
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu_;
};

std::vector<double> not_a_knot_second_derivatives(const std::vector<double>& x, const std::vector<double>& y) {
  NotAKnot system(x);
  const Eigen::Map<const Eigen::VectorXd> values(y.data(), static_cast<Eigen::Index>(y.size()));
  const Eigen::VectorXd m = system.solve(system.rhs_operator() * values);
  return std::vector<double>(m.data(), m.data() + m.size());
}

// K of the third-derivative-jump penalty: J' J with J the weighted jumps of
// the not-a-knot interpolant's third derivative at knots 2 .. n-3 (the jumps
// at knots 1 and n-2 are zero by construction).
Eigen::MatrixXd jump_penalty(const std::vector<double>& x) {
  NotAKnot system(x);
  const Eigen::MatrixXd m = system.solve(system.rhs_operator());  // second derivatives per value
  const std::vector<double>& h = system.intervals();
  const auto n = static_cast<Eigen::Index>(x.size());
  Eigen::MatrixXd j(n - 4, n);
  for (Eigen::Index k = 2; k + 2 < n; ++k) {
    const double h0 = h[static_cast<std::size_t>(k - 1)];
    const double h1 = h[static_cast<std::size_t>(k)];
    const double weight = 1.0 / std::sqrt(0.5 * (h0 + h1));
    j.row(k - 2) = weight * ((m.row(k + 1) - m.row(k)) / h1 - (m.row(k) - m.row(k - 1)) / h0);
  }
  return j.transpose() * j;
}

// The classical smoothing spline's matrices (Green & Silverman 1994, Section
// 2.1.2) for knots x: Q (n x n-2) and R (n-2 x n-2, tridiagonal), with the
// penalty integral g''^2 = g' Q R^-1 Q' g and the interior second
// derivatives gamma = R^-1 Q' g.
struct Curvature {
  Eigen::MatrixXd q;
  Eigen::LLT<Eigen::MatrixXd> r;
};

Curvature curvature_penalty(const std::vector<double>& x) {
  const auto n = static_cast<Eigen::Index>(x.size());
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n, n - 2);
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(n - 2, n - 2);
  auto h = [&](Eigen::Index i) { return x[static_cast<std::size_t>(i + 1)] - x[static_cast<std::size_t>(i)]; };
  for (Eigen::Index j = 1; j + 1 < n; ++j) {
    const Eigen::Index c = j - 1;  // column of interior knot j
    q(j - 1, c) = 1.0 / h(j - 1);
    q(j, c) = -1.0 / h(j - 1) - 1.0 / h(j);
    q(j + 1, c) = 1.0 / h(j);
    r(c, c) = (h(j - 1) + h(j)) / 3.0;
    if (c + 1 < n - 2) {
      r(c, c + 1) = h(j) / 6.0;
      r(c + 1, c) = h(j) / 6.0;
    }
  }
  return Curvature{std::move(q), Eigen::LLT<Eigen::MatrixXd>(r)};
}

// The fit for every lambda through the eigenvectors U and eigenvalues d of
// K = Q R^-1 Q': the hat matrix is A = U diag(1 / (1 + lambda d)) U'.
class DemmlerReinsch {
 public:
  DemmlerReinsch(const Eigen::MatrixXd& k, const std::vector<double>& y,
                 std::vector<std::vector<std::size_t>> blocks = {})
      : blocks_(std::move(blocks)) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (k + k.transpose()));
    d_ = eig.eigenvalues().cwiseMax(0.0);
    u_ = eig.eigenvectors();
    u2_ = u_.cwiseAbs2();
    y_ = Eigen::Map<const Eigen::VectorXd>(y.data(), static_cast<Eigen::Index>(y.size()));
    z_ = u_.transpose() * y_;
    n_ = static_cast<double>(y.size());
    if (!blocks_.empty()) index_block_pairs();
  }

  double dof(double lambda) const { return (1.0 / (1.0 + lambda * d_.array())).sum(); }

  Eigen::VectorXd fitted(double lambda) const {
    return u_ * (z_.array() / (1.0 + lambda * d_.array())).matrix();
  }

  double criterion(double lambda, SmoothingCriterion c) const {
    if (c == SmoothingCriterion::gcv) {
      const Eigen::ArrayXd s = 1.0 / (1.0 + lambda * d_.array());
      const double rss = ((1.0 - s) * z_.array()).square().sum();
      const double free = n_ - s.sum();
      return n_ * rss / (free * free);
    }
    return loo_residuals(lambda).squaredNorm() / n_;
  }

  Eigen::VectorXd loo_residuals(double lambda) const {
    const Eigen::ArrayXd s = 1.0 / (1.0 + lambda * d_.array());
    if (!blocks_.empty()) {
      // Only the hat entries the blocks use: each a row of pair_products_
      // times s (the whole hat matrix would cost n^3 per lambda).
      const Eigen::VectorXd entries = pair_products_ * s.matrix();
      const Eigen::VectorXd e = y_ - u_ * (s * z_.array()).matrix();
      const auto n = static_cast<std::size_t>(y_.size());
      const std::vector<double> r = linear_smoother_block_residuals(e, blocks_, [&](std::size_t a, std::size_t b) {
        return entries(pair_index_[std::min(a, b) * n + std::max(a, b)]);
      });
      return Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
    }
    const Eigen::VectorXd r = y_ - u_ * (s * z_.array()).matrix();
    const Eigen::VectorXd leverage = u2_ * s.matrix();
    // A leverage of 1 (interpolation) only at lambda = 0, never on the grid.
    return (r.array() / (1.0 - leverage.array()).max(1e-12)).matrix();
  }

  // log10 lambda from near interpolation to near the penalty's null space
  // (the zero eigenvalues: a line or a cubic, left unpenalised).
  std::pair<double, double> log_lambda_range() const {
    const double d_max = d_.maxCoeff();
    double d_min = d_max;
    for (Eigen::Index i = 0; i < d_.size(); ++i) {
      if (d_(i) > 1e-9 * d_max) d_min = std::min(d_min, d_(i));
    }
    return {std::log10(1e-2 / (n_ * d_max)), std::log10(1e2 * n_ / d_min)};
  }

 private:
  // Row k of pair_products_ is U_a. * U_b. for the k-th pair (a <= b) of
  // points sharing a block, so that H_ab = that row times s.
  void index_block_pairs() {
    const auto n = static_cast<std::size_t>(y_.size());
    pair_index_.assign(n * n, -1);
    std::vector<std::pair<std::size_t, std::size_t>> pairs;
    for (const auto& b : blocks_) {
      for (std::size_t a : b) {
        for (std::size_t c : b) {
          const std::size_t lo = std::min(a, c);
          const std::size_t hi = std::max(a, c);
          if (pair_index_[lo * n + hi] >= 0) continue;
          pair_index_[lo * n + hi] = static_cast<Eigen::Index>(pairs.size());
          pairs.emplace_back(lo, hi);
        }
      }
    }
    pair_products_.resize(static_cast<Eigen::Index>(pairs.size()), u_.cols());
    for (std::size_t k = 0; k < pairs.size(); ++k) {
      pair_products_.row(static_cast<Eigen::Index>(k)) =
          u_.row(static_cast<Eigen::Index>(pairs[k].first)).cwiseProduct(u_.row(static_cast<Eigen::Index>(pairs[k].second)));
    }
  }

  Eigen::VectorXd d_;
  Eigen::MatrixXd u_;
  Eigen::MatrixXd u2_;
  Eigen::VectorXd y_;
  Eigen::VectorXd z_;
  double n_ = 0.0;
  std::vector<std::vector<std::size_t>> blocks_;  // empty: leave one out
  std::vector<Eigen::Index> pair_index_;          // n x n, -1 where no block holds both
  Eigen::MatrixXd pair_products_;
};

// log10 lambda minimising the criterion: a grid of 20 points per decade, the
// smoothest of equal values, then golden-section search between the best
// point's neighbours.
double choose_log_lambda(const DemmlerReinsch& dr, SmoothingCriterion c) {
  const auto [lo, hi] = dr.log_lambda_range();
  const int steps = std::max(2, static_cast<int>(std::ceil((hi - lo) * 20.0)));
  auto at = [&](int k) { return lo + (hi - lo) * static_cast<double>(k) / steps; };
  int best = steps;
  double best_value = dr.criterion(std::pow(10.0, at(steps)), c);
  for (int k = steps - 1; k >= 0; --k) {
    const double v = dr.criterion(std::pow(10.0, at(k)), c);
    if (v < best_value) {
      best_value = v;
      best = k;
    }
  }
  double a = at(std::max(0, best - 1));
  double b = at(std::min(steps, best + 1));
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = b - ratio * (b - a);
  double x2 = a + ratio * (b - a);
  double f1 = dr.criterion(std::pow(10.0, x1), c);
  double f2 = dr.criterion(std::pow(10.0, x2), c);
  for (int it = 0; it < 40; ++it) {
    if (f1 < f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - ratio * (b - a);
      f1 = dr.criterion(std::pow(10.0, x1), c);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + ratio * (b - a);
      f2 = dr.criterion(std::pow(10.0, x2), c);
    }
  }
  const double refined = 0.5 * (a + b);
  return dr.criterion(std::pow(10.0, refined), c) <= best_value ? refined : at(best);
}

// log10 lambda with tr(A) = dof (tr A falls monotonically with lambda).
double log_lambda_for_dof(const DemmlerReinsch& dr, double dof) {
  auto [lo, hi] = dr.log_lambda_range();
  lo -= 4.0;
  hi += 4.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (dr.dof(std::pow(10.0, mid)) > dof ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

Spline fit_interpolating_spline(std::span<const double> temp_c, std::span<const double> value, double t_min_c,
                                double t_max_c) {
  Sorted s = sorted_points(temp_c, value, 2, "spline", t_min_c, t_max_c);
  const std::size_t n = s.x.size();
  std::vector<double> m(n, 0.0);
  if (n == 3) {
    // The parabola through three points: one constant second derivative.
    const double d0 = (s.y[1] - s.y[0]) / (s.x[1] - s.x[0]);
    const double d1 = (s.y[2] - s.y[1]) / (s.x[2] - s.x[1]);
    m.assign(3, 2.0 * (d1 - d0) / (s.x[2] - s.x[0]));
  } else if (n >= 4) {
    m = not_a_knot_second_derivatives(s.x, s.y);
  }
  return make_spline(std::move(s), std::move(m));
}

SmoothingSplineFit fit_smoothing_spline(std::span<const double> temp_c, std::span<const double> value,
                                        const SmoothingOptions& options, double t_min_c, double t_max_c) {
  const bool jumps = options.penalty == SmoothingPenalty::third_derivative_jumps;
  const std::size_t null_space = jumps ? 4 : 2;
  Sorted s = sorted_points(temp_c, value, null_space + 1, "smoothing spline", t_min_c, t_max_c);
  const std::size_t n = s.x.size();
  if (n > kMaxSmoothingPoints) {
    throw std::invalid_argument("smoothing spline: " + std::to_string(n) + " points, at most " +
                                std::to_string(kMaxSmoothingPoints) + " (bin the data more coarsely)");
  }
  if (options.dof != 0.0 &&
      !(options.dof > static_cast<double>(null_space) && options.dof < static_cast<double>(n))) {
    throw std::invalid_argument("smoothing spline: dof must lie between " + std::to_string(null_space) +
                                " and the number of points (" + std::to_string(n) + ")");
  }
  std::optional<Curvature> curvature;
  if (!jumps) curvature = curvature_penalty(s.x);
  const DemmlerReinsch dr(jumps ? jump_penalty(s.x) : Eigen::MatrixXd(curvature->q * curvature->r.solve(curvature->q.transpose())),
                          s.y, options.block_c > 0.0 ? held_out_blocks(s.x, options.block_c)
                                                     : std::vector<std::vector<std::size_t>>{});
  if (options.lambda < 0.0 || !std::isfinite(options.lambda)) {
    throw std::invalid_argument("smoothing spline: lambda must be a positive number");
  }
  const double log_lambda = options.lambda > 0.0 ? std::log10(options.lambda)
                            : options.dof != 0.0 ? log_lambda_for_dof(dr, options.dof)
                                                 : choose_log_lambda(dr, options.criterion);
  SmoothingSplineFit fit;
  fit.lambda = std::pow(10.0, log_lambda);
  fit.dof = dr.dof(fit.lambda);
  fit.criterion = dr.criterion(fit.lambda, options.criterion);
  const Eigen::VectorXd loo = dr.loo_residuals(fit.lambda);
  fit.loo_residuals.resize(n);
  for (std::size_t i = 0; i < n; ++i) fit.loo_residuals[s.order[i]] = loo(static_cast<Eigen::Index>(i));
  const Eigen::VectorXd g = dr.fitted(fit.lambda);
  s.y.assign(g.data(), g.data() + g.size());
  std::vector<double> m(n, 0.0);  // natural ends for the curvature penalty
  if (jumps) {
    m = not_a_knot_second_derivatives(s.x, s.y);
  } else {
    const Eigen::VectorXd gamma = curvature->r.solve(curvature->q.transpose() * g);
    for (std::size_t i = 1; i + 1 < n; ++i) m[i] = gamma(static_cast<Eigen::Index>(i - 1));
    extend_linearly(s, m);
  }
  fit.spline = make_spline(std::move(s), std::move(m));
  return fit;
}

}  // namespace gyrotc::fit
