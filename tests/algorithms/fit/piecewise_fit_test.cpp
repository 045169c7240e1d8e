#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/algorithms/fit/piecewise_fit.hpp"
#include "gyrotc_catch.hpp"
#include "table2.hpp"

using namespace gyrotc::fit;

namespace {
constexpr double kScale = 8.774;  // seed Table 2 note, mV/(deg/s)

// A curve with a kink at 20 C: a line below, a parabola above.
double kinked(double t) { return t <= 20.0 ? 50.0 + 0.5 * t : 60.0 + 0.02 * (t - 20.0) * (t - 20.0); }
}  // namespace

TEST_CASE("given breakpoints and orders, each segment fits its own points") {
  std::vector<double> t, v;
  for (double x = -40.0; x <= 80.0; x += 5.0) {
    t.push_back(x);
    v.push_back(kinked(x));
  }
  const PiecewiseFit fit = fit_piecewise(t, v, PiecewiseSpec{{20.0}, {1, 2}, false});
  const BiasModel m = BiasModel::piecewise(fit.pw);
  for (double x = -40.0; x <= 80.0; x += 2.5) CHECK(m.bias_mv(x) == Approx(kinked(x)).margin(1e-9));
}

TEST_CASE("a continuous piecewise fit has equal values at the breakpoints") {
  const auto table = gyrotc::test::read_table2();
  const PiecewiseFit fit = fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}, true});
  for (std::size_t i = 0; i < 2; ++i) {
    const double b = fit.pw.breakpoints_c[i];
    CHECK(evaluate(fit.pw.segments[i], b) == Approx(evaluate(fit.pw.segments[i + 1], b)).margin(1e-9));
  }
  const PiecewiseFit loose = fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-7.5, 52.5}, {3, 3, 2}, false});
  CHECK(std::fabs(evaluate(loose.pw.segments[0], -7.5) - evaluate(loose.pw.segments[1], -7.5)) > 1e-3);
}

TEST_CASE("a segment with too few points for its order is rejected naming it") {
  const auto table = gyrotc::test::read_table2();
  CHECK_THROWS_WITH(fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{-30.0}, {3, 3}, false}),
                    Catch::Contains("segment 1"));
  CHECK_THROWS_WITH(fit_piecewise(table.temp_c, table.gyro_mv, PiecewiseSpec{{90.0}, {1, 1}, false}),
                    Catch::Contains("breakpoint"));
}

TEST_CASE("the automatic search finds the kink of a piecewise curve") {
  std::vector<double> t, v;
  for (double x = -40.0; x <= 80.0; x += 5.0) {
    t.push_back(x);
    v.push_back(kinked(x) + 0.01 * std::sin(7.0 * x));  // a little deterministic noise
  }
  const PiecewiseChoice c = choose_piecewise(t, v, PiecewiseSearch{3, 4});
  REQUIRE(c.spec.breakpoints_c.size() >= 1);
  bool near_kink = false;
  for (double b : c.spec.breakpoints_c) near_kink = near_kink || std::fabs(b - 20.0) <= 2.5;
  CHECK(near_kink);
  CHECK(c.loo_rms < 0.05);
}

TEST_CASE("the seed's segmentation refitted: in-sample max about 0.18 and LOO max about 0.56 deg/s") {
  const auto table = gyrotc::test::read_table2();
  MethodOptions o;
  o.method = Method::paper;
  const MethodFit f = fit_method(table.temp_c, table.gyro_mv, o);
  CHECK(f.errors.in_sample_max_abs / kScale == Approx(0.18).margin(0.01));
  CHECK(f.errors.loo_max_abs / kScale == Approx(0.56).margin(0.02));
}

TEST_CASE("auto predicts unseen temperatures better than the seed's segmentation") {
  const auto table = gyrotc::test::read_table2();
  MethodOptions o;
  o.method = Method::automatic;
  const MethodFit f = fit_method(table.temp_c, table.gyro_mv, o);
  CHECK(f.errors.loo_max_abs / kScale <= 0.45);
  CHECK(f.errors.loo_rms / kScale <= 0.16);
  CHECK(f.method != Method::automatic);
  CHECK_FALSE(f.choice.empty());
}

TEST_CASE("the polynomial method picks its order by leave-one-out unless given") {
  const auto table = gyrotc::test::read_table2();
  MethodOptions o;
  o.method = Method::polynomial;
  const MethodFit chosen = fit_method(table.temp_c, table.gyro_mv, o);
  for (int order : {2, 3, 5}) {
    o.orders = {order};
    const MethodFit fixed = fit_method(table.temp_c, table.gyro_mv, o);
    CHECK(fixed.structure == "order " + std::to_string(order));
    CHECK(chosen.errors.loo_rms <= fixed.errors.loo_rms);
  }
  o.orders = {30};
  CHECK_THROWS_WITH(fit_method(table.temp_c, table.gyro_mv, o), Catch::Contains("needs at least 31 points"));
}
