#include "gyrotc/algorithms/fit/piecewise_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "gyrotc/algorithms/fit/cross_validation.hpp"
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

// The derivative of those powers with respect to temperature.
void power_slopes(const Polynomial& frame, int order, double temp_c, double* out) {
  const double x = (temp_c - frame.center_c) / frame.scale_c;
  double p = 1.0;  // x^(j-1)
  out[0] = 0.0;
  for (int j = 1; j <= order; ++j) {
    out[j] = static_cast<double>(j) * p / frame.scale_c;
    p *= x;
  }
}

int constraints_per_breakpoint(Continuity c) { return c == Continuity::none ? 0 : c == Continuity::value ? 1 : 2; }

// Joined segments as one least-squares problem: minimise |X b - y| subject
// to C b = 0 (equal value, and slope, at each breakpoint), solved as
// b = Z g with Z an orthonormal basis of the null space of C.
struct JointSystem {
  std::vector<Polynomial> frames;
  std::vector<Eigen::Index> offset;
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  Eigen::MatrixXd z;
};

JointSystem joint_system(const std::vector<Segment>& segments, Continuity continuity) {
  JointSystem js;
  Eigen::Index params = 0;
  Eigen::Index rows = 0;
  for (const Segment& seg : segments) {
    js.frames.push_back(scaled_frame(seg));
    js.offset.push_back(params);
    params += seg.order + 1;
    rows += static_cast<Eigen::Index>(seg.temp_c.size());
  }
  js.x = Eigen::MatrixXd::Zero(rows, params);
  js.y.resize(rows);
  std::vector<double> buf(static_cast<std::size_t>(params) + 1);
  Eigen::Index r = 0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    for (std::size_t i = 0; i < segments[s].temp_c.size(); ++i, ++r) {
      powers(js.frames[s], segments[s].order, segments[s].temp_c[i], buf.data());
      for (int j = 0; j <= segments[s].order; ++j) js.x(r, js.offset[s] + j) = buf[static_cast<std::size_t>(j)];
      js.y(r) = segments[s].value[i];
    }
  }
  const int per = constraints_per_breakpoint(continuity);
  const auto k = (static_cast<Eigen::Index>(segments.size()) - 1) * per;
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(k, params);
  Eigen::Index row = 0;
  for (std::size_t s = 0; s + 1 < segments.size(); ++s) {
    const double at = segments[s].hi_c;
    for (int d = 0; d < per; ++d, ++row) {
      auto basis = d == 0 ? powers : power_slopes;
      basis(js.frames[s], segments[s].order, at, buf.data());
      for (int j = 0; j <= segments[s].order; ++j) c(row, js.offset[s] + j) = buf[static_cast<std::size_t>(j)];
      basis(js.frames[s + 1], segments[s + 1].order, at, buf.data());
      for (int j = 0; j <= segments[s + 1].order; ++j) c(row, js.offset[s + 1] + j) = -buf[static_cast<std::size_t>(j)];
    }
  }
  if (k == 0) {
    js.z = Eigen::MatrixXd::Identity(params, params);
  } else {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> cqr(c.transpose());
    const Eigen::MatrixXd q = cqr.householderQ();
    js.z = q.rightCols(params - cqr.rank());
  }
  return js;
}

std::vector<Polynomial> fit_joint(const std::vector<Segment>& segments, Continuity continuity,
                                  double& condition_number) {
  JointSystem js = joint_system(segments, continuity);
  const Eigen::MatrixXd xz = js.x * js.z;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(xz);
  if (qr.rank() < xz.cols()) throw std::invalid_argument("piecewise: joined fit is not determined by the data");
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(xz);
  condition_number = svd.singularValues()(0) / svd.singularValues()(svd.singularValues().size() - 1);
  const Eigen::VectorXd beta = js.z * qr.solve(js.y);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const auto n = static_cast<Eigen::Index>(segments[s].order) + 1;
    js.frames[s].coefficients_mv.assign(beta.data() + js.offset[s], beta.data() + js.offset[s] + n);
  }
  return std::move(js.frames);
}

// Closed-form leave-one-out residuals of a joined fit, in the order of the
// segments' points; empty when the fit is not determined by the data.
std::vector<double> joint_loo(const std::vector<Segment>& segments, Continuity continuity) {
  const JointSystem js = joint_system(segments, continuity);
  const Eigen::MatrixXd xz = js.x * js.z;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(xz);
  if (qr.rank() < xz.cols() || xz.rows() <= xz.cols()) return {};
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(xz.rows(), xz.cols());
  const Eigen::VectorXd fitted = q * (q.transpose() * js.y);
  std::vector<double> loo(static_cast<std::size_t>(xz.rows()));
  for (Eigen::Index i = 0; i < xz.rows(); ++i) {
    const double h = q.row(i).squaredNorm();
    if (h > 1.0 - 1e-9) return {};  // a point that alone fixes a parameter: no LOO prediction
    loo[static_cast<std::size_t>(i)] = (js.y(i) - fitted(i)) / (1.0 - h);
  }
  return loo;
}

}  // namespace

PiecewiseSpec paper_spec() {
  // Seed Section 4.2: -40..-20 C order 4, -20..50 C order 3, 50..80 C order 4.
  return PiecewiseSpec{{-20.0, 50.0}, {4, 3, 4}, Continuity::none};
}

int piecewise_dof(const PiecewiseSpec& spec) {
  int dof = 0;
  for (int o : spec.orders) dof += o + 1;
  return dof - static_cast<int>(spec.breakpoints_c.size()) * constraints_per_breakpoint(spec.continuity);
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
  if (spec.continuity != Continuity::none && segments.size() > 1) {
    fit.pw.segments = fit_joint(segments, spec.continuity, fit.condition_number);
  } else {
    for (const Segment& seg : segments) {
      PolynomialFit p = fit_polynomial(seg.temp_c, seg.value, seg.order, seg.lo_c, seg.hi_c);
      fit.condition_number = std::max(fit.condition_number, p.condition_number);
      fit.pw.segments.push_back(std::move(p.poly));
    }
  }
  return fit;
}

namespace {

// Every structure of the search over sorted points t, v: runs of consecutive
// points (starts), orders, and the closed-form LOO residuals in sorted order.
class StructureSearch {
 public:
  StructureSearch(std::vector<double> t, std::vector<double> v, const PiecewiseSearch& search, Continuity continuity)
      : t_(std::move(t)), v_(std::move(v)), search_(search), continuity_(continuity) {}

  void run() {
    std::vector<std::size_t> starts{0};
    std::vector<int> orders;
    extend(starts, orders);
  }

  const std::vector<PiecewiseSpec>& specs() const { return specs_; }
  const std::vector<CvScore>& scores() const { return scores_; }
  const std::vector<std::vector<double>>& residuals() const { return residuals_; }

 private:
  // Adds a segment starting at starts.back(): each end and order it may take.
  void extend(std::vector<std::size_t>& starts, std::vector<int>& orders) {
    const std::size_t n = t_.size();
    const std::size_t begin = starts.back();
    for (int o = 0; o <= search_.max_order; ++o) {
      const auto need = static_cast<std::size_t>(o) + 3;
      orders.push_back(o);
      // This segment runs to the end.
      if (n - begin >= need) evaluate(starts, orders);
      // Or ends before another segment.
      if (static_cast<int>(starts.size()) < search_.max_segments) {
        for (std::size_t next = begin + need; next + 3 <= n; ++next) {
          starts.push_back(next);
          extend(starts, orders);
          starts.pop_back();
        }
      }
      orders.pop_back();
    }
  }

  void evaluate(const std::vector<std::size_t>& starts, const std::vector<int>& orders) {
    PiecewiseSpec spec;
    spec.orders = orders;
    spec.continuity = continuity_;
    std::vector<Segment> segments(starts.size());
    for (std::size_t s = 0; s < starts.size(); ++s) {
      const std::size_t end = s + 1 < starts.size() ? starts[s + 1] : t_.size();
      Segment& seg = segments[s];
      seg.order = orders[s];
      seg.temp_c.assign(t_.begin() + static_cast<std::ptrdiff_t>(starts[s]), t_.begin() + static_cast<std::ptrdiff_t>(end));
      seg.value.assign(v_.begin() + static_cast<std::ptrdiff_t>(starts[s]), v_.begin() + static_cast<std::ptrdiff_t>(end));
      seg.lo_c = s == 0 ? t_.front() : 0.5 * (t_[starts[s] - 1] + t_[starts[s]]);
      seg.hi_c = s + 1 == starts.size() ? t_.back() : 0.5 * (t_[end - 1] + t_[end]);
      if (s > 0) spec.breakpoints_c.push_back(seg.lo_c);
    }
    std::vector<double> loo = joint_loo(segments, continuity_);
    if (loo.empty()) return;
    scores_.push_back(cv_score(piecewise_dof(spec), loo));
    specs_.push_back(std::move(spec));
    residuals_.push_back(std::move(loo));
  }

  std::vector<double> t_;
  std::vector<double> v_;
  PiecewiseSearch search_;
  Continuity continuity_;
  std::vector<PiecewiseSpec> specs_;
  std::vector<CvScore> scores_;
  std::vector<std::vector<double>> residuals_;
};

}  // namespace

PiecewiseChoice choose_piecewise(std::span<const double> temp_c, std::span<const double> value,
                                 const PiecewiseSearch& search, Continuity continuity) {
  const std::size_t n = temp_c.size();
  if (n < 3 || value.size() != n) throw std::invalid_argument("piecewise search: need at least 3 points");
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) { return temp_c[a] < temp_c[b]; });
  std::vector<double> t(n);
  std::vector<double> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = temp_c[idx[i]];
    v[i] = value[idx[i]];
    if (i > 0 && !(t[i] > t[i - 1])) throw std::invalid_argument("piecewise search: repeated temperature");
  }
  StructureSearch structures(std::move(t), std::move(v), search, continuity);
  structures.run();
  if (structures.specs().empty()) throw std::invalid_argument("piecewise search: too few points for any segment");
  const std::size_t best = one_standard_error_choice(structures.scores());
  PiecewiseChoice choice;
  choice.spec = structures.specs()[best];
  choice.candidates = structures.specs().size();
  choice.loo_residuals.resize(n);
  for (std::size_t i = 0; i < n; ++i) choice.loo_residuals[idx[i]] = structures.residuals()[best][i];
  return choice;
}

}  // namespace gyrotc::fit
