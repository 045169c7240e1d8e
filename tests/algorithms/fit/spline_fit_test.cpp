#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/polynomial_fit.hpp"
#include "gyrotc/algorithms/fit/spline_fit.hpp"
#include "gyrotc/algorithms/model/random.hpp"
#include "gyrotc/algorithms/stats/summary.hpp"
#include "gyrotc_catch.hpp"
#include "table2.hpp"

using namespace gyrotc::fit;

namespace {

double cubic(double t) { return 80.0 - 0.4 * t + 0.01 * t * t - 1.5e-4 * t * t * t; }

// Uneven temperatures, so that nothing relies on equal spacing.
std::vector<double> uneven_temperatures() { return {-40.0, -33.0, -25.0, -19.0, -8.0, 0.0, 4.0, 15.0, 27.0, 33.0, 48.0, 61.0, 70.0, 80.0}; }

// A smooth curve that is not a polynomial, with known truth.
double smooth_truth(double t) { return 90.0 - 20.0 * std::tanh((t - 15.0) / 25.0) + 3.0 * std::sin(t / 17.0); }

}  // namespace

TEST_CASE("the not-a-knot spline reproduces any cubic exactly, also beyond its end knots") {
  const std::vector<double> t = uneven_temperatures();
  std::vector<double> v;
  for (double x : t) v.push_back(cubic(x));
  const BiasModel m = BiasModel::spline(fit_interpolating_spline(t, v, -50.0, 90.0));
  for (double x = -50.0; x <= 90.0; x += 0.7) CHECK(m.bias_mv(x) == Approx(cubic(x)).margin(1e-8));
}

TEST_CASE("the interpolating spline passes through every point with continuous slope and curvature") {
  const auto table = gyrotc::test::read_table2();
  const Spline sp = fit_interpolating_spline(table.temp_c, table.gyro_mv);
  for (std::size_t i = 0; i < table.temp_c.size(); ++i) CHECK(evaluate(sp, table.temp_c[i]) == Approx(table.gyro_mv[i]).margin(1e-9));
  const double h = 1e-4;
  for (std::size_t i = 1; i + 1 < sp.knots_c.size(); ++i) {
    const double x = sp.knots_c[i];
    const double left = (evaluate(sp, x) - evaluate(sp, x - h)) / h;
    const double right = (evaluate(sp, x + h) - evaluate(sp, x)) / h;
    CHECK(left == Approx(right).margin(5e-3));
    const double curv_left = (evaluate(sp, x) - 2.0 * evaluate(sp, x - h) + evaluate(sp, x - 2.0 * h)) / (h * h);
    const double curv_right = (evaluate(sp, x + 2.0 * h) - 2.0 * evaluate(sp, x + h) + evaluate(sp, x)) / (h * h);
    CHECK(curv_left == Approx(curv_right).margin(0.05));
  }
}

TEST_CASE("the not-a-knot spline's LOO on Table 2 is the figure SciPy's CubicSpline gives: 0.424 / 0.138 deg/s") {
  // Issue 20: computed with scipy.interpolate.CubicSpline (not-a-knot, the
  // end cubics extrapolated), independently of this code.
  const auto table = gyrotc::test::read_table2();
  const std::vector<double> loo = loo_residuals(table.temp_c, table.gyro_mv, [](auto t, auto v, double lo, double hi) {
    return BiasModel::spline(fit_interpolating_spline(t, v, lo, hi));
  });
  CHECK(gyrotc::stats::max_abs(loo) / Compensator::kSeedScaleMvPerDps == Approx(0.424).margin(0.0005));
  CHECK(gyrotc::stats::rms(loo) / Compensator::kSeedScaleMvPerDps == Approx(0.138).margin(0.0005));
}

TEST_CASE("two points give the line and three the parabola through them") {
  const std::vector<double> t2{0.0, 10.0}, v2{1.0, 6.0};
  CHECK(evaluate(fit_interpolating_spline(t2, v2), 4.0) == Approx(3.0));
  const std::vector<double> t3{0.0, 10.0, 30.0}, v3{0.0, 100.0, 900.0};  // T^2
  CHECK(evaluate(fit_interpolating_spline(t3, v3), 20.0) == Approx(400.0));
}

TEST_CASE("spline fits refuse repeated temperatures, too few points and non-finite values") {
  const std::vector<double> t{0.0, 1.0, 1.0, 2.0}, v{1.0, 2.0, 3.0, 4.0};
  CHECK_THROWS_WITH(fit_interpolating_spline(t, v), Catch::Contains("appears twice"));
  const std::vector<double> one{1.0};
  CHECK_THROWS_AS(fit_interpolating_spline(one, one), std::invalid_argument);
  const std::vector<double> t4{0.0, 1.0, 2.0, 3.0}, v4{1.0, 2.0, 3.0, 4.0};
  CHECK_THROWS_WITH(fit_smoothing_spline(t4, v4), Catch::Contains("at least 5"));
  const std::vector<double> bad{1.0, std::nan(""), 3.0, 4.0};
  CHECK_THROWS_WITH(fit_interpolating_spline(t4, bad), Catch::Contains("non-finite"));
}

TEST_CASE("heavy smoothing tends to the least-squares cubic (jump penalty) or line (curvature penalty)") {
  const std::vector<double> t = uneven_temperatures();
  std::vector<double> v;
  for (double x : t) v.push_back(smooth_truth(x));
  SmoothingOptions jumps;
  jumps.dof = 4.0001;
  const BiasModel smooth = BiasModel::spline(fit_smoothing_spline(t, v, jumps).spline);
  const BiasModel cubic_fit = BiasModel::polynomial(fit_polynomial(t, v, 3).poly);
  SmoothingOptions curvature;
  curvature.penalty = SmoothingPenalty::curvature;
  curvature.dof = 2.0001;
  const BiasModel flat = BiasModel::spline(fit_smoothing_spline(t, v, curvature).spline);
  const BiasModel line = BiasModel::polynomial(fit_polynomial(t, v, 1).poly);
  for (double x = -40.0; x <= 80.0; x += 5.0) {
    CHECK(smooth.bias_mv(x) == Approx(cubic_fit.bias_mv(x)).margin(0.01));
    CHECK(flat.bias_mv(x) == Approx(line.bias_mv(x)).margin(0.01));
  }
}

TEST_CASE("a smoothing spline fitted for given effective parameters has that many") {
  const std::vector<double> t = uneven_temperatures();
  std::vector<double> v;
  for (double x : t) v.push_back(smooth_truth(x));
  for (double dof : {5.0, 8.0, 12.5}) {
    SmoothingOptions o;
    o.dof = dof;
    CHECK(fit_smoothing_spline(t, v, o).dof == Approx(dof).epsilon(1e-6));
  }
  SmoothingOptions too_many;
  too_many.dof = 14.0;
  CHECK_THROWS_WITH(fit_smoothing_spline(t, v, too_many), Catch::Contains("dof"));
}

TEST_CASE("the chosen smoothing follows the noise: more noise, fewer effective parameters") {
  std::vector<double> t;
  for (double x = -40.0; x <= 80.0; x += 2.5) t.push_back(x);
  for (SmoothingCriterion criterion : {SmoothingCriterion::loo, SmoothingCriterion::gcv}) {
    double quiet_dof = 0.0;
    double noisy_dof = 0.0;
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      gyrotc::model::Random rng(seed);
      std::vector<double> quiet, noisy;
      for (double x : t) {
        const double e = rng.normal();
        quiet.push_back(smooth_truth(x) + 0.01 * e);
        noisy.push_back(smooth_truth(x) + 1.0 * e);
      }
      SmoothingOptions o;
      o.criterion = criterion;
      quiet_dof += fit_smoothing_spline(t, quiet, o).dof;
      noisy_dof += fit_smoothing_spline(t, noisy, o).dof;
    }
    CHECK(noisy_dof < 0.7 * quiet_dof);
  }
}

TEST_CASE("on noisy points of a smooth curve the penalised spline is nearer the truth than the interpolant") {
  std::vector<double> t;
  for (double x = -40.0; x <= 80.0; x += 5.0) t.push_back(x);
  double smooth_sse = 0.0;
  double interp_sse = 0.0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    gyrotc::model::Random rng(100 + seed);
    std::vector<double> v;
    for (double x : t) v.push_back(smooth_truth(x) + 0.8 * rng.normal());
    const Spline smooth = fit_smoothing_spline(t, v).spline;
    const Spline interp = fit_interpolating_spline(t, v);
    for (double x = -40.0; x <= 80.0; x += 1.0) {
      smooth_sse += std::pow(evaluate(smooth, x) - smooth_truth(x), 2);
      interp_sse += std::pow(evaluate(interp, x) - smooth_truth(x), 2);
    }
  }
  CHECK(smooth_sse < 0.8 * interp_sse);
}

TEST_CASE("the classical smoothing spline's closed-form LOO residuals equal refits without each point") {
  // With the curvature penalty the spline minimises over all smooth
  // functions, so leaving a point out is giving it zero weight: the refit
  // at the same lambda (a separate fit on the other knots, extended as a
  // line to a left-out end) must predict exactly y_i - r_i / (1 - A_ii).
  const auto table = gyrotc::test::read_table2();
  SmoothingOptions o;
  o.penalty = SmoothingPenalty::curvature;
  o.dof = 12.0;
  const SmoothingSplineFit fit = fit_smoothing_spline(table.temp_c, table.gyro_mv, o);
  SmoothingOptions same = o;
  same.dof = 0.0;
  same.lambda = fit.lambda;
  const std::vector<double> refit = loo_residuals(table.temp_c, table.gyro_mv, [&](auto t, auto v, double lo, double hi) {
    return BiasModel::spline(fit_smoothing_spline(t, v, same, lo, hi).spline);
  });
  REQUIRE(refit.size() == fit.loo_residuals.size());
  for (std::size_t i = 0; i < refit.size(); ++i) {
    INFO("point " << i);
    CHECK(fit.loo_residuals[i] == Approx(refit[i]).margin(1e-7));
  }
}
