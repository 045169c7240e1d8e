// The O(n^2) Toeplitz inverse against Eigen's dense factorisation.
#include <cmath>

#include "gyrotc/algorithms/stats/toeplitz.hpp"
#include "gyrotc_catch.hpp"

using gyrotc::stats::toeplitz_inverse;

namespace {

Eigen::MatrixXd toeplitz(const Eigen::VectorXd& c) {
  const Eigen::Index n = c.size();
  Eigen::MatrixXd t(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) t(i, j) = c(std::abs(i - j));
  }
  return t;
}

}  // namespace

TEST_CASE("the Toeplitz inverse and log-determinant match a dense factorisation, for every size 1..12 and 101") {
  for (Eigen::Index n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 101}) {
    // An AR(1)-like correlation plus a white part, scaled: positive definite.
    Eigen::VectorXd c(n);
    for (Eigen::Index h = 0; h < n; ++h) c(h) = 2.5 * (std::pow(0.8, static_cast<double>(h)) + (h == 0 ? 0.3 : 0.0));
    const auto got = toeplitz_inverse(c);
    INFO("n = " << n);
    REQUIRE(got.ok);
    const Eigen::MatrixXd t = toeplitz(c);
    const Eigen::LLT<Eigen::MatrixXd> llt(t);
    const double log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
    CHECK(got.log_det == Approx(log_det).epsilon(1e-10));
    CHECK((got.inverse * t - Eigen::MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff() < 1e-9);
  }
}

TEST_CASE("a Toeplitz matrix that is not positive definite is refused") {
  Eigen::VectorXd c(3);
  c << 1.0, 0.9, -0.9;  // correlations no series can have
  CHECK_FALSE(toeplitz_inverse(c).ok);
  CHECK_FALSE(toeplitz_inverse(Eigen::VectorXd::Zero(4)).ok);
  CHECK_FALSE(toeplitz_inverse(Eigen::VectorXd()).ok);
}
