#include "gyrotc/algorithms/stats/allan_covariance.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace gyrotc::stats {

namespace {

constexpr int kTypes = 4;
constexpr int kPairs = 10;
// Accumulators: the 10 products C_j C_k, then the 4 first moments C_j (for
// the cross term of a deterministic ramp's mean with the noise).
constexpr int kSums = kPairs + kTypes;

// Index of the type pair (j <= k) in the 10 parts.
int pair_index(int j, int k) {
  static constexpr int kIndex[kTypes][kTypes] = {{0, 1, 2, 3}, {1, 4, 5, 6}, {2, 5, 7, 8}, {3, 6, 8, 9}};
  return kIndex[j][k];
}

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
struct GaussLegendre {
  static constexpr int kNodes = 12;
  std::array<double, kNodes> x{};
  std::array<double, kNodes> w{};
  GaussLegendre() {
    for (int i = 0; i < kNodes; ++i) {
      double z = std::cos(std::numbers::pi * (i + 0.75) / (kNodes + 0.5));
      double dp = 0.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0;
        double p1 = z;
        for (int k = 2; k <= kNodes; ++k) {
          const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = kNodes * (z * p1 - p0) / (z * z - 1.0);
        const double dz = p1 / dp;
        z -= dz;
        if (std::fabs(dz) < 1e-15) break;
      }
      x[static_cast<std::size_t>(i)] = z;
      w[static_cast<std::size_t>(i)] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
  }
};

const GaussLegendre& gauss_legendre() {
  static const GaussLegendre g;
  return g;
}

// The finite-difference weights of an estimate and its normalisation:
// E[d^2] = the variance for d = w . theta / sqrt(scale m^2 tau0^2).
struct Differences {
  std::array<double, 4> w{};
  int order = 2;
  double scale = 2.0;
};

Differences differences_of(int order) {
  if (order == 3) return {{1.0, -3.0, 3.0, -1.0}, 3, 6.0};
  return {{1.0, -2.0, 1.0, 0.0}, 2, 2.0};
}

// The lag covariances of one pair of estimates, for every noise type at
// unit Allan-variance coefficient.
class PairKernel {
 public:
  PairKernel(const Differences& d1, const Differences& d2, double m1, double m2, double big_m1, double big_m2,
             double tau0)
      : d1_(d1), d2_(d2), m1_(m1), m2_(m2), big_m1_(big_m1), big_m2_(big_m2), tau0_(tau0),
        norm_(1.0 / (std::sqrt(d1.scale * d2.scale) * m1 * m2 * tau0 * tau0)) {}

  // C_j(h) for the 4 noise types: the covariance of d_k(m1) and d_{k+h}(m2);
  // `with_spikes` includes quantisation's delta (only at integer lags where
  // an argument is exactly zero).
  std::array<double, kTypes> lag_covariance(double h, bool with_spikes) const {
    std::array<double, kTypes> c{};
    for (int a = 0; a <= d1_.order; ++a) {
      for (int b = 0; b <= d2_.order; ++b) {
        const double t = h + b * m2_ - a * m1_;
        const double ww = d1_.w[static_cast<std::size_t>(a)] * d2_.w[static_cast<std::size_t>(b)];
        const double at = std::fabs(t);
        if (with_spikes && at < 0.5) c[0] += ww / 3.0;
        c[1] += ww * (-0.5 * tau0_ * at);
        if (at > 0.0) c[2] += ww * tau0_ * tau0_ * t * t * std::log(at) / (4.0 * std::numbers::ln2);
        c[3] += ww * 0.25 * tau0_ * tau0_ * tau0_ * at * at * at;
      }
    }
    for (double& v : c) v *= norm_;
    return c;
  }

  // n(h) C_j(h) C_k(h) for the 10 type pairs at lag h, then n(h) C_j(h).
  void products(double h, bool with_spikes, std::array<double, kSums>& out) const {
    const std::array<double, kTypes> c = lag_covariance(h, with_spikes);
    const double n = count(h);
    for (int j = 0; j < kTypes; ++j) {
      for (int k = j; k < kTypes; ++k) {
        out[static_cast<std::size_t>(pair_index(j, k))] = n * c[static_cast<std::size_t>(j)] * c[static_cast<std::size_t>(k)];
      }
      out[static_cast<std::size_t>(kPairs + j)] = n * c[static_cast<std::size_t>(j)];
    }
  }

  // Index pairs (k, l) with l - k = h, k < M1, l < M2.
  double count(double h) const { return std::max(0.0, std::min(big_m1_, big_m2_ - h) - std::max(0.0, -h)); }

 private:
  Differences d1_, d2_;
  double m1_, m2_, big_m1_, big_m2_, tau0_, norm_;
};

// sum_{h = lo}^{hi} n(h) C_j(h) C_k(h) for every type pair, and n(h) C_j(h).
std::array<double, kSums> lag_sums(const PairKernel& kernel, int order1, int order2, double m1, double m2,
                                   double big_m1, double big_m2) {
  const double lo = -(big_m1 - 1.0);
  const double hi = big_m2 - 1.0;
  // Kinks: where an argument of the generalised covariance is zero, and n(h)'s.
  std::vector<double> cuts{lo, hi, 0.0, big_m2 - big_m1};
  for (int a = 0; a <= order1; ++a) {
    for (int b = 0; b <= order2; ++b) cuts.push_back(a * m1 - b * m2);
  }
  // The flicker tail, beyond the outermost kinks, in doubling steps (the
  // first moments of a compact kernel vanish there too).
  const double reach = 64.0 * (m1 + m2);
  const double right = order1 * m1;
  const double left = -order2 * m2;
  for (double d = m1 + m2; d <= reach; d *= 2.0) {
    cuts.push_back(right + d);
    cuts.push_back(left - d);
  }
  std::vector<double> points;
  for (double x : cuts) {
    if (x >= std::max(lo, left - reach) && x <= std::min(hi, right + reach)) points.push_back(x);
  }
  std::sort(points.begin(), points.end());
  points.erase(std::unique(points.begin(), points.end()), points.end());
  std::array<double, kSums> sum{};
  std::array<double, kSums> f{};
  auto add = [&](double scale) {
    for (int i = 0; i < kSums; ++i) sum[static_cast<std::size_t>(i)] += scale * f[static_cast<std::size_t>(i)];
  };
  const GaussLegendre& gl = gauss_legendre();
  for (std::size_t p = 0; p < points.size(); ++p) {
    kernel.products(points[p], true, f);
    add(1.0);
    if (p + 1 == points.size()) break;
    const double u = points[p];
    const double v = points[p + 1];
    if (v - u - 1.0 <= 64.0) {
      for (double h = u + 1.0; h < v; h += 1.0) {
        kernel.products(h, true, f);
        add(1.0);
      }
      continue;
    }
    // Euler-Maclaurin: sum_{u < h < v} f = integral - (f(u) + f(v)) / 2 - (f'(v) - f'(u)) / 12,
    // the ends from inside the interval (no quantisation spikes there).
    constexpr int kPanels = 4;
    const double width = (v - u) / kPanels;
    for (int q = 0; q < kPanels; ++q) {
      const double a = u + q * width;
      for (int i = 0; i < GaussLegendre::kNodes; ++i) {
        kernel.products(a + 0.5 * width * (1.0 + gl.x[static_cast<std::size_t>(i)]), false, f);
        add(0.5 * width * gl.w[static_cast<std::size_t>(i)]);
      }
    }
    std::array<double, kSums> fu{}, fu1{}, fu2{}, fv{}, fv1{}, fv2{};
    kernel.products(u, false, fu);
    kernel.products(u + 1.0, false, fu1);
    kernel.products(u + 2.0, false, fu2);
    kernel.products(v, false, fv);
    kernel.products(v - 1.0, false, fv1);
    kernel.products(v - 2.0, false, fv2);
    for (int i = 0; i < kSums; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const double du = (-3.0 * fu[k] + 4.0 * fu1[k] - fu2[k]) / 2.0;
      const double dv = (3.0 * fv[k] - 4.0 * fv1[k] + fv2[k]) / 2.0;
      sum[k] -= 0.5 * (fu[k] + fv[k]) + (dv - du) / 12.0;
    }
  }
  return sum;
}

}  // namespace

std::array<double, 4> difference_covariance(const VarianceEstimate& e1, const VarianceEstimate& e2, double h,
                                            double tau0_s) {
  // The counts of index pairs play no part in one lag's covariance.
  const PairKernel kernel(differences_of(e1.differences), differences_of(e2.differences), static_cast<double>(e1.m),
                          static_cast<double>(e2.m), 0.0, 0.0, tau0_s);
  return kernel.lag_covariance(h, true);
}

namespace {

std::vector<VarianceEstimate> allan_estimates(std::span<const std::size_t> m) {
  std::vector<VarianceEstimate> e;
  for (std::size_t v : m) e.push_back({v, 2});
  return e;
}

}  // namespace

AvarCovariance::AvarCovariance(std::span<const std::size_t> m, std::size_t samples, double tau0_s)
    : AvarCovariance(allan_estimates(m), samples, tau0_s) {}

AvarCovariance::AvarCovariance(std::span<const VarianceEstimate> estimates, std::size_t samples, double tau0_s)
    : points_(estimates.size()) {
  if (!(tau0_s > 0.0)) throw std::invalid_argument("allan covariance: tau0 must be positive");
  for (const VarianceEstimate& e : estimates) {
    if (e.differences != 2 && e.differences != 3) throw std::invalid_argument("allan covariance: differences must be 2 or 3");
    if (e.m < 1 || static_cast<std::size_t>(e.differences) * e.m > samples) {
      throw std::invalid_argument("allan covariance: need 1 <= differences * m <= samples");
    }
  }
  const auto p = static_cast<Eigen::Index>(points_);
  for (auto& part : parts_) part = Eigen::MatrixXd::Zero(p, p);
  for (auto& part : ramp_parts_) part = Eigen::MatrixXd::Zero(p, p);
  tau_s_.resize(p);
  expected_.resize(p, kTypes);
  const double n_phase = static_cast<double>(samples) + 1.0;
  for (std::size_t i = 0; i < points_; ++i) {
    const VarianceEstimate& e = estimates[i];
    const auto m = static_cast<double>(e.m);
    tau_s_(static_cast<Eigen::Index>(i)) = e.differences == 2 ? m * tau0_s : 0.0;
    const std::array<double, kTypes> c0 = difference_covariance(e, e, 0.0, tau0_s);
    for (int j = 0; j < kTypes; ++j) expected_(static_cast<Eigen::Index>(i), j) = c0[static_cast<std::size_t>(j)];
  }
  for (std::size_t i = 0; i < points_; ++i) {
    for (std::size_t j = i; j < points_; ++j) {
      const VarianceEstimate& e1 = estimates[i];
      const VarianceEstimate& e2 = estimates[j];
      const auto m1 = static_cast<double>(e1.m);
      const auto m2 = static_cast<double>(e2.m);
      const double big_m1 = n_phase - e1.differences * m1;
      const double big_m2 = n_phase - e2.differences * m2;
      const PairKernel kernel(differences_of(e1.differences), differences_of(e2.differences), m1, m2, big_m1, big_m2,
                              tau0_s);
      const std::array<double, kSums> s = lag_sums(kernel, e1.differences, e2.differences, m1, m2, big_m1, big_m2);
      const auto ii = static_cast<Eigen::Index>(i);
      const auto jj = static_cast<Eigen::Index>(j);
      for (int a = 0; a < kTypes; ++a) {
        for (int b = a; b < kTypes; ++b) {
          const int k = pair_index(a, b);
          const double value = 2.0 / (big_m1 * big_m2) * s[static_cast<std::size_t>(k)] * (a == b ? 1.0 : 2.0);
          parts_[static_cast<std::size_t>(k)](ii, jj) = value;
          parts_[static_cast<std::size_t>(k)](jj, ii) = value;
        }
        const double first = 4.0 / (big_m1 * big_m2) * s[static_cast<std::size_t>(kPairs + a)];
        ramp_parts_[static_cast<std::size_t>(a)](ii, jj) = first;
        ramp_parts_[static_cast<std::size_t>(a)](jj, ii) = first;
      }
    }
  }
}

Eigen::MatrixXd AvarCovariance::covariance(const std::array<double, 4>& c, double ramp) const {
  const auto p = static_cast<Eigen::Index>(points_);
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(p, p);
  if (ramp > 0.0) {
    // The ramp's means mu_p = sqrt(ramp) tau_p times the noise's first moments.
    const Eigen::MatrixXd tau_tau = tau_s_ * tau_s_.transpose();
    for (int a = 0; a < kTypes; ++a) {
      const double w = c[static_cast<std::size_t>(a)];
      if (w != 0.0) out += (ramp * w) * ramp_parts_[static_cast<std::size_t>(a)].cwiseProduct(tau_tau);
    }
  }
  for (int a = 0; a < kTypes; ++a) {
    for (int b = a; b < kTypes; ++b) {
      const double w = c[static_cast<std::size_t>(a)] * c[static_cast<std::size_t>(b)];
      if (w != 0.0) out += w * parts_[static_cast<std::size_t>(pair_index(a, b))];
    }
  }
  return out;
}

}  // namespace gyrotc::stats
