#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/allan_edf.hpp"
#include "gyrotc/algorithms/stats/chi_square.hpp"

namespace gyrotc::stats {

namespace {

constexpr double kTwoLn2OverPi = 0.44127462871889788;  // 2 ln 2 / pi (IEEE 952 C.1.3)
// An estimate whose noise is all deterministic (a pure ramp) has no
// sampling variance; this EDF stands for "exact" without dividing by zero.
constexpr double kMaxEdf = 1e9;

std::optional<PowerLawNoise> noise_type(NoiseTerm t) {
  switch (t) {
    case NoiseTerm::quantisation: return PowerLawNoise::quantisation;
    case NoiseTerm::angle_random_walk: return PowerLawNoise::white_rate;
    case NoiseTerm::bias_instability: return PowerLawNoise::flicker_rate;
    case NoiseTerm::rate_random_walk: return PowerLawNoise::random_walk_rate;
    case NoiseTerm::rate_ramp: return std::nullopt;
  }
  return std::nullopt;
}

// One Allan point prepared for the fit: its estimate, the powers of tau and
// the EDF each noise type would give it.
struct Point {
  double avar = 0.0;
  std::array<double, kNoiseTerms> basis{};  // tau^power of each term
  std::array<double, kNoiseTerms> edf{};    // per term's noise type (kMaxEdf for the ramp)
};

using Coefficients = std::array<double, kNoiseTerms>;

double model_avar(const Point& p, const Coefficients& c) {
  double a = 0.0;
  for (std::size_t j = 0; j < kNoiseTerms; ++j) a += c[j] * p.basis[j];
  return a;
}

double point_edf(const Point& p, const Coefficients& c) {
  double total = 0.0;
  double spread = 0.0;  // sum of share_j^2 / nu_j, unnormalised
  for (std::size_t j = 0; j < kNoiseTerms; ++j) {
    const double part = c[j] * p.basis[j];
    total += part;
    spread += part * part / p.edf[j];
  }
  if (!(spread > 0.0)) return kMaxEdf;
  return std::min(kMaxEdf, total * total / spread);
}

// Gamma log-density of the estimate: avar ~ A chi^2_nu / nu, shape k = nu / 2.
double log_density(double avar, double model, double edf) {
  const double k = 0.5 * edf;
  return k * std::log(k) - std::lgamma(k) + (k - 1.0) * std::log(avar) - k * std::log(model) - k * avar / model;
}

struct SubsetFit {
  Coefficients c{};
  Eigen::MatrixXd covariance;  // of the included coefficients, naive (independent points)
  std::vector<std::size_t> terms;
  double log_likelihood = -std::numeric_limits<double>::infinity();
  bool ok = false;
};

double log_likelihood(const std::vector<Point>& points, const Coefficients& c) {
  double l = 0.0;
  for (const Point& p : points) l += log_density(p.avar, model_avar(p, c), point_edf(p, c));
  return l;
}

// Fisher scoring for the coefficients of `terms` (all others zero), kept
// positive by step halving; a term whose coefficient collapses to nothing
// makes the subset infeasible (the subset without it is fitted on its own).
SubsetFit fit_subset(const std::vector<Point>& points, const std::vector<std::size_t>& terms) {
  SubsetFit fit;
  fit.terms = terms;
  const auto t = static_cast<Eigen::Index>(terms.size());
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < t) return fit;
  // Start: least squares of the relative misfit, (model - avar) / avar.
  Eigen::MatrixXd a(n, t);
  Eigen::VectorXd ones = Eigen::VectorXd::Ones(n);
  Eigen::VectorXd scale(t);
  for (Eigen::Index j = 0; j < t; ++j) {
    double biggest = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Point& p = points[static_cast<std::size_t>(i)];
      biggest = std::max(biggest, p.basis[terms[static_cast<std::size_t>(j)]] / p.avar);
    }
    scale(j) = 1.0 / biggest;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Point& p = points[static_cast<std::size_t>(i)];
      a(i, j) = p.basis[terms[static_cast<std::size_t>(j)]] / p.avar * scale(j);
    }
  }
  const Eigen::VectorXd start = a.colPivHouseholderQr().solve(ones);
  Coefficients c{};
  for (Eigen::Index j = 0; j < t; ++j) {
    const std::size_t term = terms[static_cast<std::size_t>(j)];
    // A negative start: a coefficient that gives 1 % of the smallest estimate.
    c[term] = start(j) > 0.0 ? start(j) * scale(j) : 0.01 * scale(j);
  }
  double current = log_likelihood(points, c);
  Eigen::MatrixXd info(t, t);
  for (int iteration = 0; iteration < 200; ++iteration) {
    info.setZero();
    Eigen::VectorXd score = Eigen::VectorXd::Zero(t);
    for (const Point& p : points) {
      const double model = model_avar(p, c);
      const double w = 0.5 * point_edf(p, c) / (model * model);
      for (Eigen::Index j = 0; j < t; ++j) {
        const double xj = p.basis[terms[static_cast<std::size_t>(j)]];
        score(j) += w * (p.avar - model) * xj;
        for (Eigen::Index k = 0; k < t; ++k) info(j, k) += w * xj * p.basis[terms[static_cast<std::size_t>(k)]];
      }
    }
    // Solve in coefficients relative to their current values (the powers of
    // tau span many decades).
    Eigen::VectorXd rel(t);
    for (Eigen::Index j = 0; j < t; ++j) rel(j) = c[terms[static_cast<std::size_t>(j)]];
    const Eigen::MatrixXd scaled = rel.asDiagonal() * info * rel.asDiagonal();
    const Eigen::VectorXd step = scaled.ldlt().solve(rel.asDiagonal() * score);  // relative step
    if (!step.allFinite()) return fit;
    double length = 1.0;
    Coefficients next = c;
    bool improved = false;
    for (int halving = 0; halving < 40; ++halving, length *= 0.5) {
      bool positive = true;
      for (Eigen::Index j = 0; j < t; ++j) {
        const std::size_t term = terms[static_cast<std::size_t>(j)];
        next[term] = c[term] * (1.0 + length * step(j));
        positive = positive && next[term] > 0.0;
      }
      if (!positive) continue;
      const double trial = log_likelihood(points, next);
      if (trial >= current - 1e-12 * std::fabs(current)) {
        improved = true;
        current = trial;
        break;
      }
    }
    if (!improved) break;
    const double change = (length * step).cwiseAbs().maxCoeff();
    c = next;
    if (change < 1e-10) break;
  }
  // Every term must matter somewhere: at least 0.01 % of the model at some point.
  for (std::size_t term : terms) {
    double share = 0.0;
    for (const Point& p : points) share = std::max(share, c[term] * p.basis[term] / model_avar(p, c));
    if (share < 1e-4) return fit;
  }
  info.setZero();
  for (const Point& p : points) {
    const double model = model_avar(p, c);
    const double w = 0.5 * point_edf(p, c) / (model * model);
    for (Eigen::Index j = 0; j < t; ++j) {
      for (Eigen::Index k = 0; k < t; ++k) {
        info(j, k) += w * p.basis[terms[static_cast<std::size_t>(j)]] * p.basis[terms[static_cast<std::size_t>(k)]];
      }
    }
  }
  Eigen::VectorXd rel(t);
  for (Eigen::Index j = 0; j < t; ++j) rel(j) = c[terms[static_cast<std::size_t>(j)]];
  const Eigen::MatrixXd scaled = rel.asDiagonal() * info * rel.asDiagonal();
  const Eigen::MatrixXd relative_cov = scaled.ldlt().solve(Eigen::MatrixXd::Identity(t, t));
  if (!relative_cov.allFinite()) return fit;
  fit.covariance = rel.asDiagonal() * relative_cov * rel.asDiagonal();
  fit.c = c;
  fit.log_likelihood = current;
  fit.ok = std::isfinite(current);
  return fit;
}

}  // namespace

std::string_view noise_term_name(NoiseTerm term) {
  switch (term) {
    case NoiseTerm::quantisation: return "quantisation";
    case NoiseTerm::angle_random_walk: return "angle_random_walk";
    case NoiseTerm::bias_instability: return "bias_instability";
    case NoiseTerm::rate_random_walk: return "rate_random_walk";
    case NoiseTerm::rate_ramp: return "rate_ramp";
  }
  return "unknown";
}

int noise_term_power(NoiseTerm term) { return static_cast<int>(term) - 2; }

double avar_coefficient(NoiseTerm term, double value) {
  const double v2 = value * value;
  switch (term) {
    case NoiseTerm::quantisation: return 3.0 * v2;
    case NoiseTerm::angle_random_walk: return v2;
    case NoiseTerm::bias_instability: return kTwoLn2OverPi * v2;
    case NoiseTerm::rate_random_walk: return v2 / 3.0;
    case NoiseTerm::rate_ramp: return 0.5 * v2;
  }
  return v2;
}

double term_value(NoiseTerm term, double c) { return std::sqrt(c / avar_coefficient(term, 1.0)); }

double NoiseFit::avar(double tau_s) const {
  double a = 0.0;
  for (NoiseTerm t : kAllNoiseTerms) {
    const TermEstimate& e = term(t);
    if (e.included) a += avar_coefficient(t, e.value) * std::pow(tau_s, noise_term_power(t));
  }
  return a;
}

double mixture_edf(const NoiseFit& fit, double tau_s, std::size_t m, std::size_t samples) {
  Point p;
  Coefficients c{};
  for (NoiseTerm t : kAllNoiseTerms) {
    const auto j = static_cast<std::size_t>(t);
    const auto type = noise_type(t);
    p.basis[j] = std::pow(tau_s, noise_term_power(t));
    p.edf[j] = type ? overlapping_avar_edf(*type, m, samples) : kMaxEdf;
    if (fit.term(t).included) c[j] = avar_coefficient(t, fit.term(t).value);
  }
  return point_edf(p, c);
}

NoiseFit fit_noise_terms(std::span<const AllanPoint> points, std::size_t samples, const AllanOptions& options) {
  std::vector<Point> prepared;
  for (const AllanPoint& ap : points) {
    if (!(ap.adev > 0.0) || !std::isfinite(ap.adev) || ap.m < 1 || 2 * ap.m > samples) continue;
    Point p;
    p.avar = ap.adev * ap.adev;
    for (NoiseTerm t : kAllNoiseTerms) {
      const auto j = static_cast<std::size_t>(t);
      const auto type = noise_type(t);
      p.basis[j] = std::pow(ap.tau_s, noise_term_power(t));
      p.edf[j] = type ? overlapping_avar_edf(*type, ap.m, samples) : kMaxEdf;
    }
    prepared.push_back(p);
  }
  NoiseFit out;
  if (prepared.size() < 2) return out;
  const double phi = options.correlation_factor;
  std::optional<SubsetFit> best;
  double best_criterion = std::numeric_limits<double>::infinity();
  for (unsigned mask = 1; mask < (1u << kNoiseTerms); ++mask) {
    std::vector<std::size_t> terms;
    for (std::size_t j = 0; j < kNoiseTerms; ++j) {
      if ((mask >> j) & 1u) terms.push_back(j);
    }
    SubsetFit f = fit_subset(prepared, terms);
    ++out.models_compared;
    if (!f.ok) continue;
    const double criterion = -2.0 * f.log_likelihood / phi + options.term_penalty * static_cast<double>(terms.size());
    if (criterion < best_criterion) {
      best_criterion = criterion;
      best = std::move(f);
    }
  }
  if (!best) return out;
  out.valid = true;
  out.log_likelihood = best->log_likelihood / phi;
  out.criterion = best_criterion;
  const double z = std::sqrt(chi_square_quantile(options.confidence, 1.0));
  for (std::size_t k = 0; k < best->terms.size(); ++k) {
    const std::size_t j = best->terms[k];
    const auto term = kAllNoiseTerms[j];
    const double c = best->c[j];
    const auto kk = static_cast<Eigen::Index>(k);
    const double relative_se = std::sqrt(std::max(0.0, phi * best->covariance(kk, kk))) / c;
    TermEstimate& e = out.terms[j];
    e.included = true;
    e.value = term_value(term, c);
    e.relative_se = relative_se;
    e.ci_low = term_value(term, c * std::exp(-z * relative_se));
    e.ci_high = term_value(term, c * std::exp(z * relative_se));
  }
  return out;
}

}  // namespace gyrotc::stats
