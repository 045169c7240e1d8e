#pragma once

#include <Eigen/Dense>

#include <array>
#include <cstddef>
#include <span>

#include "gyrotc/algorithms/stats/allan_edf.hpp"

// Covariance of the overlapping Allan (and Hadamard) variance estimates at
// several cluster times of one record: neighbouring cluster times share most
// of their data, so their estimates are strongly correlated, and a fit that
// treated them as independent would claim far more precision than the record
// holds.
namespace gyrotc::stats {

// One variance estimate of a record: the overlapping Allan variance (second
// differences of the angle, IEEE 952 Eq. C.4) or the overlapping Hadamard
// variance (third differences, HVAR = <(th_{k+3m} - 3 th_{k+2m} + 3 th_{k+m}
// - th_k)^2> / (6 tau^2)), which a rate ramp does not reach.
struct VarianceEstimate {
  std::size_t m = 1;       // cluster size in samples
  int differences = 2;     // 2: Allan, 3: Hadamard
};

// The covariance of the scaled differences d_k(m1) and d_{k+h}(m2) (h in
// samples) of two estimates, for the four noise types at unit Allan-variance
// coefficient: the generalised covariance below through the differences'
// weights. E[d_k^2] is the estimate's expected value.
std::array<double, 4> difference_covariance(const VarianceEstimate& e1, const VarianceEstimate& e2, double h,
                                            double tau0_s);

// For Gaussian noise, each estimate is (1/M) sum_k d_k^2 with d_k the scaled
// second (or third) difference of the angle, and
//   Cov(a_p, a_q) = 2 / (M_p M_q) sum_h n(h) C(h)^2,
// C(h) the covariance of d_k(m_p) and d_{k+h}(m_q), n(h) the number of
// index pairs at lag h. C follows from the angle's generalised covariance
// (quantisation: delta(t) Q^2; white rate: -N^2 tau0 |t| / 2; flicker:
// t^2 ln|t| (2 ln 2 / pi) B^2 tau0^2 / (4 ln 2); random walk: K^2 tau0^3 |t|^3 / 12),
// the time-domain form of Greenhall's algorithm (allan_edf.hpp) extended to
// two cluster times: its diagonal gives the same EDF. The sum over h is
// exact over short stretches and, over long smooth ones between the kinks,
// the Euler-Maclaurin form of a Gauss-Legendre integral. The flicker term's
// lag sum is cut at 64 (m_p + m_q), beyond which it falls as h^-4.
class AvarCovariance {
 public:
  // Cluster sizes m (ascending or not) of a record of `samples` rate
  // samples at period tau0_s; needs 1 <= m <= samples / 2.
  AvarCovariance(std::span<const std::size_t> m, std::size_t samples, double tau0_s);
  // Any mix of Allan and Hadamard estimates; needs 1 <= differences * m <= samples.
  AvarCovariance(std::span<const VarianceEstimate> estimates, std::size_t samples, double tau0_s);

  // The covariance matrix of the estimates for Allan-variance coefficients
  // c of the four random noise types (PowerLawNoise order: quantisation,
  // white rate, flicker, random walk; AVAR = c tau^p as in allan.hpp) and of
  // a rate ramp (AVAR = ramp tau^2): the ramp adds no variance of its own,
  // but its mean second difference multiplies the noise's,
  // 4 mu_p mu_q / (M_p M_q) sum_h n(h) C(h) (zero for a Hadamard estimate,
  // whose mean third difference of a ramp is zero).
  Eigen::MatrixXd covariance(const std::array<double, 4>& c, double ramp = 0.0) const;

  // The expected value of estimate i for noise type j (PowerLawNoise order) at
  // unit Allan-variance coefficient: tau^p for an Allan estimate, a constant
  // times tau^p for a Hadamard one (white rate 1, random walk 1/2).
  double expected(std::size_t i, int j) const { return expected_(static_cast<Eigen::Index>(i), j); }

  std::size_t points() const { return points_; }

 private:
  std::size_t points_;
  // Per pair of noise types (j <= k, 10 of them): the covariance per unit
  // c_j c_k (the cross pairs counted for both orders).
  std::array<Eigen::MatrixXd, 10> parts_;
  // Per noise type: 4 / (M_p M_q) sum_h n(h) C_j(h), for the ramp's cross term.
  std::array<Eigen::MatrixXd, 4> ramp_parts_;
  Eigen::VectorXd tau_s_;    // tau of an Allan estimate, 0 for a Hadamard one (no ramp mean)
  Eigen::MatrixXd expected_;  // points x 4
};

}  // namespace gyrotc::stats
