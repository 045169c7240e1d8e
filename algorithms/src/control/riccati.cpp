#include "gyrotc/algorithms/control/riccati.hpp"

#include <stdexcept>
#include <string>

namespace gyrotc::control {

// The structure-preserving doubling algorithm (Chu, Fan, Lin, Wang 2004):
// quadratic convergence, where the plain recursion needs as many steps as the
// slowest closed-loop mode's time constant in periods.
Eigen::MatrixXd solve_dare(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::MatrixXd& q,
                           const Eigen::MatrixXd& r, int max_iterations) {
  const Eigen::Index n = a.rows();
  const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd ak = a;
  Eigen::MatrixXd gk = b * r.ldlt().solve(b.transpose());
  Eigen::MatrixXd hk = q;
  for (int k = 0; k < max_iterations; ++k) {
    const Eigen::PartialPivLU<Eigen::MatrixXd> w(identity + gk * hk);
    const Eigen::MatrixXd w_a = w.solve(ak);
    const Eigen::MatrixXd w_g = w.solve(gk);
    Eigen::MatrixXd h_next = hk + ak.transpose() * hk * w_a;
    gk = gk + ak * w_g * ak.transpose();
    ak = ak * w_a;
    h_next = 0.5 * (h_next + h_next.transpose());
    gk = 0.5 * (gk + gk.transpose());
    const double change = (h_next - hk).norm();
    hk = std::move(h_next);
    if (!hk.allFinite()) break;
    if (change <= 1e-12 * std::max(1.0, hk.norm())) {
      // Settled is not enough: the solution must be the stabilising one.
      const Eigen::MatrixXd bp = b.transpose() * hk;
      const Eigen::MatrixXd gain = (r + bp * b).ldlt().solve(bp * a);
      if (hk.allFinite() && spectral_radius(a - b * gain) < 1.0) return hk;
      break;
    }
  }
  throw std::invalid_argument("Riccati equation: no solution within " + std::to_string(max_iterations) +
                              " doubling steps (not stabilisable, or the weights not positive)");
}

double spectral_radius(const Eigen::MatrixXd& m) {
  return m.eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace gyrotc::control
