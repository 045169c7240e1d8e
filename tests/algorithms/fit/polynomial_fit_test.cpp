#include <cmath>
#include <stdexcept>
#include <vector>

#include "gyrotc/algorithms/fit/cross_validation.hpp"
#include "gyrotc/algorithms/fit/polynomial_fit.hpp"
#include "gyrotc_catch.hpp"
#include "table2.hpp"

using namespace gyrotc::fit;

namespace {
std::vector<double> grid(double from, double to, double step) {
  std::vector<double> out;
  for (double t = from; t <= to + 1e-9; t += step) out.push_back(t);
  return out;
}
}  // namespace

TEST_CASE("an exact polynomial is recovered from its samples") {
  const auto t = grid(-40.0, 80.0, 5.0);
  std::vector<double> v;
  for (double x : t) v.push_back(100.0 - 0.6 * x - 0.012 * x * x + 9e-5 * x * x * x);
  const PolynomialFit fit = fit_polynomial(t, v, 3);
  const BiasModel m = BiasModel::polynomial(fit.poly);
  for (double x = -40.0; x <= 80.0; x += 1.7) {
    CHECK(m.bias_mv(x) == Approx(100.0 - 0.6 * x - 0.012 * x * x + 9e-5 * x * x * x).margin(1e-9));
  }
  CHECK(fit.poly.center_c == Approx(20.0));
  CHECK(fit.poly.scale_c == Approx(60.0));
}

TEST_CASE("centring and scaling keep the design matrix well conditioned") {
  const auto table = gyrotc::test::read_table2();
  // Order 9 over -40..80 C: raw powers span 1 .. 80^9 = 1.3e17, beyond double
  // precision (and Eq. 17's normal equations square the condition number);
  // centred and scaled the design matrix stays well conditioned.
  const PolynomialFit fit = fit_polynomial(table.temp_c, table.gyro_mv, 9);
  CHECK(fit.condition_number > 1.0);
  CHECK(fit.condition_number < 1e4);
}

TEST_CASE("closed-form leave-one-out residuals equal refitting without each point") {
  const auto table = gyrotc::test::read_table2();
  const std::vector<double> fast = polynomial_loo_residuals(table.temp_c, table.gyro_mv, 5);
  const std::vector<double> slow = loo_residuals(
      table.temp_c, table.gyro_mv, [](auto t, auto v, double lo, double hi) {
        return BiasModel::polynomial(fit_polynomial(t, v, 5, lo, hi).poly);
      });
  REQUIRE(fast.size() == slow.size());
  for (std::size_t i = 0; i < fast.size(); ++i) CHECK(fast[i] == Approx(slow[i]).margin(1e-8));
}

TEST_CASE("a polynomial fit rejects too few points and duplicate temperatures") {
  const std::vector<double> t{0.0, 10.0, 20.0};
  const std::vector<double> v{1.0, 2.0, 3.0};
  CHECK_THROWS_WITH(fit_polynomial(t, v, 3), Catch::Contains("at least 4 points"));
  CHECK_THROWS_WITH(polynomial_loo_residuals(t, v, 2), Catch::Contains("at least 4 points"));
  const std::vector<double> dup{0.0, 10.0, 10.0, 10.0};
  const std::vector<double> dv{1.0, 2.0, 3.0, 4.0};
  CHECK_THROWS_WITH(fit_polynomial(dup, dv, 2), Catch::Contains("distinct"));
}
