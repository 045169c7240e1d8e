#include <cmath>

#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::control::AmbientLag;

TEST_CASE("the lagged ambient is NaN until the first reading, which starts it there") {
  AmbientLag lag;
  CHECK(std::isnan(lag.value_c()));
  lag.update(std::nan(""), 10.0, 100.0);
  CHECK(std::isnan(lag.value_c()));
  lag.update(20.0, 10.0, 100.0);
  CHECK(lag.value_c() == 20.0);
}

TEST_CASE("a lag of zero is the reading itself") {
  AmbientLag lag;
  lag.update(20.0, 0.0, 0.0);
  lag.update(-7.3, 10.0, 0.0);
  CHECK(lag.value_c() == -7.3);
}

TEST_CASE("a step of the ambient reaches 1 - 1/e of its size after one lag") {
  AmbientLag lag;
  lag.update(20.0, 0.0, 300.0);
  for (int k = 0; k < 30; ++k) lag.update(-10.0, 10.0, 300.0);
  CHECK(lag.value_c() == Approx(20.0 - 30.0 * (1.0 - std::exp(-1.0))).margin(1e-9));
}

TEST_CASE("a missing (NaN) reading leaves the lagged ambient where it was") {
  AmbientLag lag;
  lag.update(20.0, 0.0, 300.0);
  lag.update(10.0, 10.0, 300.0);
  const double before = lag.value_c();
  lag.update(std::nan(""), 10.0, 300.0);
  CHECK(lag.value_c() == before);
}
