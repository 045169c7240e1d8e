#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/algorithms/fit/piecewise_fit.hpp"
#include "gyrotc/algorithms/fit/polynomial_fit.hpp"
#include "gyrotc_catch.hpp"
#include "table2.hpp"

using namespace gyrotc::fit;

namespace {

// A curve with a kink at 20 C: a line below, a parabola above.
double kinked(double t) { return t <= 20.0 ? 50.0 + 0.5 * t : 60.0 + 0.02 * (t - 20.0) * (t - 20.0); }

double slope(const Polynomial& p, double t) {
  const double h = 1e-5;
  return (evaluate(p, t + h) - evaluate(p, t - h)) / (2.0 * h);
}

double sum_squares(const BiasModel& m, const std::vector<double>& t, const std::vector<double>& v, double lo,
                   double hi) {
  double s = 0.0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (t[i] < lo || t[i] > hi) continue;
    const double r = v[i] - m.bias_mv(t[i]);
    s += r * r;
  }
  return s;
}

}  // namespace

TEST_CASE("given breakpoints and orders, each segment fits its own points") {
  std::vector<double> t, v;
  for (double x = -40.0; x <= 80.0; x += 5.0) {
    t.push_back(x);
    v.push_back(kinked(x));
  }
  const PiecewiseFit fit = fit_piecewise(t, v, PiecewiseSpec{{20.0}, {1, 2}, Continuity::none});
  const BiasModel m = BiasModel::piecewise(fit.pw);
  for (double x = -40.0; x <= 80.0; x += 2.5) CHECK(m.bias_mv(x) == Approx(kinked(x)).margin(1e-9));
}

TEST_CASE("joined segments have equal values, and with slope continuity equal slopes, at the breakpoints") {
  const auto table = gyrotc::test::read_table2();
  const PiecewiseFit value = fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}});
  const PiecewiseFit smooth =
      fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}, Continuity::slope});
  const PiecewiseFit loose =
      fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}, Continuity::none});
  for (std::size_t i = 0; i < 2; ++i) {
    const double b = value.pw.breakpoints_c[i];
    CHECK(evaluate(value.pw.segments[i], b) == Approx(evaluate(value.pw.segments[i + 1], b)).margin(1e-9));
    CHECK(evaluate(smooth.pw.segments[i], b) == Approx(evaluate(smooth.pw.segments[i + 1], b)).margin(1e-9));
    CHECK(slope(smooth.pw.segments[i], b) == Approx(slope(smooth.pw.segments[i + 1], b)).margin(1e-5));
    // Value continuity alone leaves a corner; independent segments step.
    CHECK(std::fabs(slope(value.pw.segments[i], b) - slope(value.pw.segments[i + 1], b)) > 1e-3);
    CHECK(std::fabs(evaluate(loose.pw.segments[i], b) - evaluate(loose.pw.segments[i + 1], b)) > 1e-3);
  }
}

TEST_CASE("a joined fit is the least-squares fit among curves that meet at the breakpoints") {
  // Perturbing the fit along any direction that keeps the segments joined
  // (here: shifting every segment by the same constant, or tilting the
  // middle one about its breakpoints would break the join, so only the
  // common shift) cannot lower the sum of squares.
  const auto table = gyrotc::test::read_table2();
  const PiecewiseFit fit = fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}});
  const double best = sum_squares(BiasModel::piecewise(fit.pw), table.temp_c, table.gyro_mv, -40.0, 80.0);
  for (double shift : {-0.05, 0.05}) {
    Piecewise moved = fit.pw;
    for (auto& seg : moved.segments) seg.coefficients_mv[0] += shift;
    CHECK(sum_squares(BiasModel::piecewise(moved), table.temp_c, table.gyro_mv, -40.0, 80.0) > best);
  }
  // The independent fit has more freedom, so its sum of squares is no larger.
  const PiecewiseFit loose =
      fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}, Continuity::none});
  CHECK(sum_squares(BiasModel::piecewise(loose.pw), table.temp_c, table.gyro_mv, -40.0, 80.0) <= best + 1e-9);
}

TEST_CASE("a segment with too few points for its order is rejected naming it") {
  const auto table = gyrotc::test::read_table2();
  CHECK_THROWS_WITH(fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-30.0}, {3, 3}, Continuity::none}),
                    Catch::Contains("segment 1"));
  CHECK_THROWS_WITH(fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{90.0}, {1, 1}, Continuity::none}),
                    Catch::Contains("breakpoint"));
}

TEST_CASE("the automatic search finds the kink of a piecewise curve") {
  std::vector<double> t, v;
  for (double x = -40.0; x <= 80.0; x += 5.0) {
    t.push_back(x);
    v.push_back(kinked(x) + 0.01 * std::sin(7.0 * x));  // a little deterministic noise
  }
  for (Continuity continuity : {Continuity::none, Continuity::value}) {
    const PiecewiseChoice c = choose_piecewise(t, v, PiecewiseSearch{2, 2}, continuity);
    REQUIRE(c.spec.breakpoints_c.size() == 1);
    CHECK(std::fabs(c.spec.breakpoints_c[0] - 20.0) <= 2.5);
    if (continuity == Continuity::none) {
      // Independent segments can put the kink between 20 and 25 C exactly.
      double sse = 0.0;
      for (double r : c.loo_residuals) sse += r * r;
      CHECK(std::sqrt(sse / static_cast<double>(t.size())) < 0.05);
    }
  }
}

TEST_CASE("the search keeps order + 3 points in every segment") {
  const auto table = gyrotc::test::read_table2();
  const std::vector<double> t(table.temp_c.begin(), table.temp_c.begin() + 16);
  const std::vector<double> v(table.gyro_mv.begin(), table.gyro_mv.begin() + 16);
  for (Continuity continuity : {Continuity::none, Continuity::value, Continuity::slope}) {
    const PiecewiseChoice c = choose_piecewise(t, v, PiecewiseSearch{3, 3}, continuity);
    std::vector<std::size_t> count(c.spec.orders.size(), 0);
    for (double x : t) {
      std::size_t s = 0;
      while (s < c.spec.breakpoints_c.size() && x > c.spec.breakpoints_c[s]) ++s;
      ++count[s];
    }
    for (std::size_t s = 0; s < count.size(); ++s) {
      INFO("segment " << s << " order " << c.spec.orders[s]);
      CHECK(count[s] >= static_cast<std::size_t>(c.spec.orders[s]) + 3);
    }
  }
}

TEST_CASE("the closed-form LOO of a joined structure equals refitting without each point") {
  const auto table = gyrotc::test::read_table2();
  // A structure the search can return: its residuals come from the hat
  // matrix; the refits below go through fit_piecewise, a separate path.
  std::vector<double> t(table.temp_c.begin(), table.temp_c.begin() + 12);
  std::vector<double> v(table.gyro_mv.begin(), table.gyro_mv.begin() + 12);
  const PiecewiseChoice c = choose_piecewise(t, v, PiecewiseSearch{2, 2}, Continuity::value);
  const std::vector<double> refit = loo_residuals(t, v, [&](auto ft, auto fv, double lo, double hi) {
    return BiasModel::piecewise(fit_piecewise(ft, fv, c.spec, ShortSegment::reject, lo, hi).pw);
  });
  REQUIRE(refit.size() == c.loo_residuals.size());
  for (std::size_t i = 0; i < refit.size(); ++i) CHECK(c.loo_residuals[i] == Approx(refit[i]).margin(1e-7));
}

TEST_CASE("the seed's segmentation refitted is the least-squares fit of each segment") {
  // The seed printed least-squares coefficients of the same segmentation for
  // the same points (data/README.md, with the erratum): our refit must fit
  // each segment at least as well.
  const auto table = gyrotc::test::read_table2();
  MethodOptions o;
  o.method = Method::paper;
  const MethodFit f = fit_method(table.temp_c, table.gyro_mv, o);
  const BiasModel printed = BiasModel::paper_reference();
  const double ranges[3][2] = {{-40.0, -20.0}, {-19.0, 50.0}, {51.0, 80.0}};
  for (const auto& r : ranges) {
    INFO("segment " << r[0] << " .. " << r[1]);
    CHECK(sum_squares(f.model, table.temp_c, table.gyro_mv, r[0], r[1]) <=
          sum_squares(printed, table.temp_c, table.gyro_mv, r[0], r[1]) + 1e-9);
  }
}

TEST_CASE("the LOO of a fixed structure equals each segment's hat-matrix formula") {
  // paper: independent segments of orders 4/3/4; the middle and last
  // segments have points to spare, so their refit LOO residuals must equal
  // r_i / (1 - h_ii) of a polynomial fitted to the segment alone.
  const auto table = gyrotc::test::read_table2();
  const Fitter paper = [](auto ft, auto fv, double lo, double hi) {
    return BiasModel::piecewise(fit_piecewise(ft, fv, paper_spec(), ShortSegment::lower_order, lo, hi).pw);
  };
  const std::vector<double> loo = loo_residuals(table.temp_c, table.gyro_mv, paper);
  std::vector<double> mt, mv;
  for (std::size_t i = 0; i < table.temp_c.size(); ++i) {
    if (table.temp_c[i] > -20.0 && table.temp_c[i] <= 50.0) {
      mt.push_back(table.temp_c[i]);
      mv.push_back(table.gyro_mv[i]);
    }
  }
  const std::vector<double> hat = polynomial_loo_residuals(mt, mv, 3);
  for (std::size_t i = 0, k = 0; i < table.temp_c.size(); ++i) {
    if (table.temp_c[i] > -20.0 && table.temp_c[i] <= 50.0) CHECK(loo[i] == Approx(hat[k++]).margin(1e-8));
  }
}
