#include "gyrotc/algorithms/fit/piecewise_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/fit/polynomial_fit.hpp"

namespace gyrotc::fit {

namespace {

struct Segment {
  std::vector<double> temp_c;
  std::vector<double> value;
  int order = 0;
  double lo_c = 0.0;
  double hi_c = 0.0;
};

std::vector<Segment> split(std::span<const double> temp_c, std::span<const double> value,
                           const PiecewiseSpec& spec, ShortSegment short_segment, double t_min_c,
                           double t_max_c) {
  const std::size_t count = spec.orders.size();
  if (count == 0 || spec.breakpoints_c.size() + 1 != count) {
    throw std::invalid_argument("piecewise: need one order per segment and one breakpoint fewer (" +
                                std::to_string(spec.orders.size()) + " orders, " +
                                std::to_string(spec.breakpoints_c.size()) + " breakpoints)");
  }
  for (std::size_t i = 0; i < spec.breakpoints_c.size(); ++i) {
    const double b = spec.breakpoints_c[i];
    const double below = i == 0 ? t_min_c : spec.breakpoints_c[i - 1];
    if (!std::isfinite(b) || !(b > below) || !(b < t_max_c)) {
      throw std::invalid_argument("piecewise: breakpoint " + std::to_string(b) +
                                  " must be ascending and inside the data range");
    }
  }
  std::vector<Segment> segments(count);
  for (std::size_t s = 0; s < count; ++s) {
    segments[s].order = spec.orders[s];
    segments[s].lo_c = s == 0 ? t_min_c : spec.breakpoints_c[s - 1];
    segments[s].hi_c = s + 1 == count ? t_max_c : spec.breakpoints_c[s];
    if (spec.orders[s] < 0) throw std::invalid_argument("piecewise: negative order");
  }
  for (std::size_t i = 0; i < temp_c.size(); ++i) {
    std::size_t s = 0;
    while (s < spec.breakpoints_c.size() && temp_c[i] > spec.breakpoints_c[s]) ++s;
    segments[s].temp_c.push_back(temp_c[i]);
    segments[s].value.push_back(value[i]);
  }
  for (std::size_t s = 0; s < count; ++s) {
    Segment& seg = segments[s];
    const auto have = static_cast<int>(seg.temp_c.size());
    if (have >= seg.order + 1) continue;
    if (short_segment == ShortSegment::lower_order && have > 0) {
      seg.order = have - 1;
      continue;
    }
    throw std::invalid_argument("piecewise: segment " + std::to_string(s + 1) + " (" +
                                std::to_string(seg.lo_c) + " .. " + std::to_string(seg.hi_c) +
                                " C) has " + std::to_string(have) + " points, order " +
                                std::to_string(spec.orders[s]) + " needs at least " +
                                std::to_string(spec.orders[s] + 1));
  }
  return segments;
}

Polynomial scaled_frame(const Segment& seg) {
  Polynomial p;
  p.center_c = 0.5 * (seg.lo_c + seg.hi_c);
  p.scale_c = 0.5 * (seg.hi_c - seg.lo_c);
  p.t_min_c = seg.lo_c;
  p.t_max_c = seg.hi_c;
  return p;
}

// Powers 1, x, ..., x^order of the segment's scaled temperature.
void powers(const Polynomial& frame, int order, double temp_c, double* out) {
  const double x = (temp_c - frame.center_c) / frame.scale_c;
  double p = 1.0;
  for (int j = 0; j <= order; ++j) {
    out[j] = p;
    p *= x;
  }
}

// Equality-constrained least squares: minimise |X b - y| subject to C b = 0,
// with b = Z g, Z an orthonormal basis of the null space of C.
std::vector<Polynomial> fit_continuous(const std::vector<Segment>& segments, double& condition_number) {
  std::vector<Polynomial> frames;
  std::vector<Eigen::Index> offset;
  Eigen::Index params = 0;
  Eigen::Index rows = 0;
  for (const Segment& seg : segments) {
    frames.push_back(scaled_frame(seg));
    offset.push_back(params);
    params += seg.order + 1;
    rows += static_cast<Eigen::Index>(seg.temp_c.size());
  }
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(rows, params);
  Eigen::VectorXd y(rows);
  std::vector<double> buf(static_cast<std::size_t>(params) + 1);
  Eigen::Index r = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    for (std::size_t i = 0; i < segments[s].temp_c.size(); ++i, ++r) {
      powers(frames[s], segments[s].order, segments[s].temp_c[i], buf.data());
      for (int j = 0; j <= segments[s].order; ++j) x(r, offset[s] + j) = buf[static_cast<std::size_t>(j)];
      y(r) = segments[s].value[i];
    }
  }
  const auto k = static_cast<Eigen::Index>(segments.size()) - 1;
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(k, params);
  for (Eigen::Index b = 0; b < k; ++b) {
    const auto s = static_cast<std::size_t>(b);
    const double at = segments[s].hi_c;
    powers(frames[s], segments[s].order, at, buf.data());
    for (int j = 0; j <= segments[s].order; ++j) c(b, offset[s] + j) = buf[static_cast<std::size_t>(j)];
    powers(frames[s + 1], segments[s + 1].order, at, buf.data());
    for (int j = 0; j <= segments[s + 1].order; ++j) c(b, offset[s + 1] + j) = -buf[static_cast<std::size_t>(j)];
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> cqr(c.transpose());
  const Eigen::MatrixXd q = cqr.householderQ();
  const Eigen::MatrixXd z = q.rightCols(params - k);
  const Eigen::MatrixXd xz = x * z;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(xz);
  if (qr.rank() < xz.cols()) throw std::invalid_argument("piecewise: continuous fit is not determined by the data");
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(xz);
  condition_number = svd.singularValues()(0) / svd.singularValues()(svd.singularValues().size() - 1);
  const Eigen::VectorXd beta = z * qr.solve(y);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const auto n = static_cast<std::size_t>(segments[s].order) + 1;
    frames[s].coefficients_mv.assign(beta.data() + offset[s], beta.data() + offset[s] + static_cast<Eigen::Index>(n));
  }
  return frames;
}

}  // namespace

PiecewiseSpec paper_spec() {
  // Seed Section 4.2: -40..-20 C order 4, -20..50 C order 3, 50..80 C order 4.
  return PiecewiseSpec{{-20.0, 50.0}, {4, 3, 4}, false};
}

PiecewiseFit fit_piecewise(std::span<const double> temp_c, std::span<const double> value,
                        const PiecewiseSpec& spec, ShortSegment short_segment, double t_min_c,
                        double t_max_c) {
  if (temp_c.size() != value.size() || temp_c.empty()) {
    throw std::invalid_argument("piecewise: need matching, non-empty temperature and value lists");
  }
  if (!(t_min_c < t_max_c)) {
    const auto [lo, hi] = std::minmax_element(temp_c.begin(), temp_c.end());
    t_min_c = *lo;
    t_max_c = *hi;
  }
  const std::vector<Segment> segments = split(temp_c, value, spec, short_segment, t_min_c, t_max_c);
  PiecewiseFit fit;
  fit.pw.breakpoints_c = spec.breakpoints_c;
  if (spec.continuous && segments.size() > 1) {
    fit.pw.segments = fit_continuous(segments, fit.condition_number);
  } else {
    for (const Segment& seg : segments) {
      PolynomialFit p = fit_polynomial(seg.temp_c, seg.value, seg.order, seg.lo_c, seg.hi_c);
      fit.condition_number = std::max(fit.condition_number, p.condition_number);
      fit.pw.segments.push_back(std::move(p.poly));
    }
  }
  return fit;
}

PiecewiseChoice choose_piecewise(std::span<const double> temp_c, std::span<const double> value,
                                 const PiecewiseSearch& search) {
  const std::size_t n = temp_c.size();
  if (n < 2 || value.size() != n) throw std::invalid_argument("piecewise search: need at least 2 points");
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return temp_c[a] < temp_c[b]; });
  std::vector<double> t(n);
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = temp_c[idx[i]];
    v[i] = value[idx[i]];
  }
  const double inf = std::numeric_limits<double>::infinity();
  // cost[i][j]: best LOO sum of squares of one segment over points i..j.
  std::vector<std::vector<double>> cost(n, std::vector<double>(n, inf));
  std::vector<std::vector<int>> order(n, std::vector<int>(n, -1));
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const auto points = static_cast<int>(j - i + 1);
      const std::span<const double> st(t.data() + i, j - i + 1);
      const std::span<const double> sv(v.data() + i, j - i + 1);
      for (int o = 0; o <= search.max_order && o + 2 <= points; ++o) {
        const std::vector<double> loo = polynomial_loo_residuals(st, sv, o);
        double sse = 0.0;
        for (double r : loo) sse += r * r;
        if (sse < cost[i][j]) {
          cost[i][j] = sse;
          order[i][j] = o;
        }
      }
    }
  }
  // best[k][j]: best cost of points 0..j in k + 1 segments; from[k][j]: start of the last one.
  const auto max_segments = static_cast<std::size_t>(std::max(1, search.max_segments));
  std::vector<std::vector<double>> best(max_segments, std::vector<double>(n, inf));
  std::vector<std::vector<std::size_t>> from(max_segments, std::vector<std::size_t>(n, 0));
  for (std::size_t j = 0; j < n; ++j) best[0][j] = cost[0][j];
  for (std::size_t k = 1; k < max_segments; ++k) {
    for (std::size_t j = 0; j < n; ++j) {
      for (std::size_t i = 1; i <= j; ++i) {
        const double c = best[k - 1][i - 1] + cost[i][j];
        if (c < best[k][j]) {
          best[k][j] = c;
          from[k][j] = i;
        }
      }
    }
  }
  std::size_t segments_used = 0;
  for (std::size_t k = 1; k < max_segments; ++k) {
    if (best[k][n - 1] < best[segments_used][n - 1]) segments_used = k;
  }
  if (!std::isfinite(best[segments_used][n - 1])) {
    throw std::invalid_argument("piecewise search: too few points for any segment");
  }
  PiecewiseChoice choice;
  choice.loo_rms = std::sqrt(best[segments_used][n - 1] / static_cast<double>(n));
  std::size_t end = n - 1;
  for (std::size_t k = segments_used + 1; k-- > 0;) {
    const std::size_t start = k == 0 ? 0 : from[k][end];
    choice.spec.orders.insert(choice.spec.orders.begin(), order[start][end]);
    if (k > 0) choice.spec.breakpoints_c.insert(choice.spec.breakpoints_c.begin(), 0.5 * (t[start - 1] + t[start]));
    end = start - 1;
  }
  return choice;
}

}  // namespace gyrotc::fit
