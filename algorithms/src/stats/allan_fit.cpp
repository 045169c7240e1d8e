#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/allan_covariance.hpp"
#include "gyrotc/algorithms/stats/allan_edf.hpp"
#include "gyrotc/algorithms/stats/allan_walk.hpp"
#include "gyrotc/algorithms/stats/chi_square.hpp"

namespace gyrotc::stats {

namespace {

constexpr double kTwoLn2OverPi = 0.44127462871889788;  // 2 ln 2 / pi (IEEE 952 C.1.3)
// An estimate whose noise is all deterministic (a pure ramp) has no
// sampling variance; this EDF stands for "exact" without dividing by zero.
constexpr double kMaxEdf = 1e9;
// Correlation length of the model discrepancy along log10 tau: a real
// spectrum departs from the power laws smoothly, over about half a decade.
constexpr double kDiscrepancyDecades = 0.5;

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

// One Allan (or Hadamard) point prepared for the fit: its estimate, each
// term's expected estimate at unit coefficient, and (for mixture_edf) the
// EDF each noise type would give an Allan point.
struct Point {
  double estimate = 0.0;                    // the Allan or Hadamard variance
  std::array<double, kNoiseTerms> basis{};  // expected estimate per unit coefficient (tau^power for Allan)
  std::array<double, kNoiseTerms> edf{};    // per term's noise type (kMaxEdf for the ramp); mixture_edf only
};

using Coefficients = std::array<double, kNoiseTerms>;

double model_estimate(const Point& p, const Coefficients& c) {
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

// Digamma and trigamma: recurrence up to x >= 8, then the asymptotic series
// (Abramowitz & Stegun 6.3.18, 6.4.12).
double digamma(double x) {
  double shift = 0.0;
  while (x < 8.0) {
    shift -= 1.0 / x;
    x += 1.0;
  }
  const double i2 = 1.0 / (x * x);
  return shift + std::log(x) - 0.5 / x - i2 * (1.0 / 12.0 - i2 * (1.0 / 120.0 - i2 / 252.0));
}

double trigamma(double x) {
  double shift = 0.0;
  while (x < 8.0) {
    shift += 1.0 / (x * x);
    x += 1.0;
  }
  const double i = 1.0 / x;
  const double i2 = i * i;
  return shift + i + 0.5 * i2 + i * i2 * (1.0 / 6.0 - i2 * (1.0 / 30.0 - i2 / 42.0));
}

// The records' points, prepared once: the logarithms of the estimates, the
// powers of tau, and the covariance of the estimates per noise type.
struct Problem {
  std::vector<Point> points;
  Eigen::VectorXd log_estimate;
  // The model discrepancy's covariance in the log domain (fixed).
  Eigen::MatrixXd discrepancy;
  std::optional<AvarCovariance> covariance;
};

// -2 log L of the log-estimates for coefficients c, with the pieces the
// Gauss-Newton step needs.
struct Evaluation {
  double minus_two_log_l = std::numeric_limits<double>::infinity();
  Eigen::VectorXd residual;  // ln a - ln A - bias
  Eigen::LDLT<Eigen::MatrixXd> factor;
  Eigen::VectorXd model;     // A
};

Evaluation evaluate(const Problem& pr, const Coefficients& c) {
  const auto n = static_cast<Eigen::Index>(pr.points.size());
  Evaluation e;
  e.model.resize(n);
  e.residual.resize(n);
  const Eigen::MatrixXd cov = pr.covariance->covariance({c[0], c[1], c[2], c[3]}, c[4]);
  Eigen::VectorXd sd(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Point& p = pr.points[static_cast<std::size_t>(i)];
    const double a = model_estimate(p, c);
    if (!(a > 0.0)) return e;
    e.model(i) = a;
    const double var = cov(i, i);
    const double nu = var > 0.0 ? std::min(kMaxEdf, 2.0 * a * a / var) : kMaxEdf;
    e.residual(i) = pr.log_estimate(i) - std::log(a) - (digamma(0.5 * nu) - std::log(0.5 * nu));
    sd(i) = std::sqrt(trigamma(0.5 * nu));
  }
  // Correlations of the estimates, carried to their logarithms, plus the
  // model's own discrepancy.
  const Eigen::VectorXd scale = sd.cwiseQuotient(cov.diagonal().cwiseSqrt());
  Eigen::MatrixXd z = scale.asDiagonal() * cov * scale.asDiagonal();
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!(cov(i, i) > 0.0)) {  // no sampling variance (a pure ramp): its own variance only
      z.row(i).setZero();
      z.col(i).setZero();
      z(i, i) = sd(i) * sd(i);
    }
  }
  z += pr.discrepancy;
  // Neighbouring estimates correlate up to 0.99: a tiny ridge keeps the
  // factorisation positive definite without changing the fit.
  z.diagonal() *= 1.0 + 1e-9;
  e.factor.compute(z);
  if (e.factor.info() != Eigen::Success || (e.factor.vectorD().array() <= 0.0).any()) return e;
  const double quad = e.residual.dot(e.factor.solve(e.residual));
  const double log_det = e.factor.vectorD().array().log().sum();
  e.minus_two_log_l = quad + log_det;
  return e;
}

struct SubsetFit {
  Coefficients c{};
  Eigen::MatrixXd log_covariance;  // of ln c of the included terms
  std::vector<std::size_t> terms;
  double minus_two_log_l = std::numeric_limits<double>::infinity();
  bool ok = false;
};

// Jacobian of ln A with respect to ln c of the included terms.
Eigen::MatrixXd jacobian(const Problem& pr, const Coefficients& c, const Eigen::VectorXd& model,
                         const std::vector<std::size_t>& terms) {
  const auto n = static_cast<Eigen::Index>(pr.points.size());
  Eigen::MatrixXd j(n, static_cast<Eigen::Index>(terms.size()));
  for (Eigen::Index i = 0; i < n; ++i) {
    for (std::size_t k = 0; k < terms.size(); ++k) {
      j(i, static_cast<Eigen::Index>(k)) = c[terms[k]] * pr.points[static_cast<std::size_t>(i)].basis[terms[k]] / model(i);
    }
  }
  return j;
}

// Gauss-Newton in ln c for the terms of the subset (the others zero), from
// the least squares of the relative misfit; a term whose coefficient
// collapses to nothing makes the subset infeasible (the subset without it
// is fitted on its own).
SubsetFit fit_subset(const Problem& pr, const std::vector<std::size_t>& terms) {
  SubsetFit fit;
  fit.terms = terms;
  const auto t = static_cast<Eigen::Index>(terms.size());
  const auto n = static_cast<Eigen::Index>(pr.points.size());
  if (n <= t) return fit;
  Eigen::MatrixXd a(n, t);
  Eigen::VectorXd scale(t);
  for (Eigen::Index j = 0; j < t; ++j) {
    double biggest = 0.0;
    for (const Point& p : pr.points) biggest = std::max(biggest, p.basis[terms[static_cast<std::size_t>(j)]] / p.estimate);
    scale(j) = 1.0 / biggest;
    for (Eigen::Index i = 0; i < n; ++i) {
      const Point& p = pr.points[static_cast<std::size_t>(i)];
      a(i, j) = p.basis[terms[static_cast<std::size_t>(j)]] / p.estimate * scale(j);
    }
  }
  const Eigen::VectorXd start = a.colPivHouseholderQr().solve(Eigen::VectorXd::Ones(n));
  Coefficients c{};
  for (Eigen::Index j = 0; j < t; ++j) {
    // A negative start: a coefficient that gives 1 % of the largest estimate it could.
    c[terms[static_cast<std::size_t>(j)]] = start(j) > 0.0 ? start(j) * scale(j) : 0.01 * scale(j);
  }
  Evaluation current = evaluate(pr, c);
  if (!std::isfinite(current.minus_two_log_l)) return fit;
  for (int iteration = 0; iteration < 50; ++iteration) {
    const Eigen::MatrixXd j = jacobian(pr, c, current.model, terms);
    const Eigen::MatrixXd wj = current.factor.solve(j);
    const Eigen::MatrixXd info = j.transpose() * wj;
    const Eigen::VectorXd step = info.ldlt().solve(wj.transpose() * current.residual);
    if (!step.allFinite()) return fit;
    double length = 1.0;
    bool improved = false;
    Coefficients next = c;
    for (int halving = 0; halving < 20; ++halving, length *= 0.5) {
      for (Eigen::Index k = 0; k < t; ++k) {
        const std::size_t term = terms[static_cast<std::size_t>(k)];
        next[term] = c[term] * std::exp(std::clamp(length * step(k), -20.0, 20.0));
      }
      Evaluation trial = evaluate(pr, next);
      if (trial.minus_two_log_l <= current.minus_two_log_l + 1e-9) {
        improved = true;
        current = std::move(trial);
        break;
      }
    }
    if (!improved) break;
    c = next;
    if ((length * step).cwiseAbs().maxCoeff() < 1e-6) break;
  }
  // Every term must matter somewhere: at least 0.01 % of the model at some point.
  for (std::size_t term : terms) {
    double share = 0.0;
    for (const Point& p : pr.points) share = std::max(share, c[term] * p.basis[term] / model_estimate(p, c));
    if (share < 1e-4) return fit;
  }
  const Eigen::MatrixXd j = jacobian(pr, c, current.model, terms);
  const Eigen::MatrixXd info = j.transpose() * current.factor.solve(j);
  fit.log_covariance = info.ldlt().solve(Eigen::MatrixXd::Identity(t, t));
  if (!fit.log_covariance.allFinite()) return fit;
  fit.c = c;
  fit.minus_two_log_l = current.minus_two_log_l;
  fit.ok = std::isfinite(current.minus_two_log_l);
  return fit;
}

// The random walk's value by REML on the record's block means, under the
// chosen model: its quantisation and white rate held, its bias instability
// (if it has one) estimated beside the walk. Only where the walk is under
// half of the fitted Allan variance at the block length: the block means
// see only tau >= T / blocks, which then holds the walk's information; a
// walk that rules down to shorter clusters (alone, say) is known far better
// from them (a random walk alone: 0.1 % median error from the fit, 1.9 %
// from the block means). The interval spans the fit's and the REML one (z
// its normal quantile); a walk not resolved keeps that status and the fit's
// upper bound, with the REML value as its value if present.
void refine_random_walk(std::span<const double> rate, double rate_hz, std::size_t blocks, double z, NoiseFit& fit) {
  TermEstimate& walk = fit.terms[static_cast<std::size_t>(NoiseTerm::rate_random_walk)];
  const double start = walk.included ? walk.value : walk.value_if_present;
  if (!(start > 0.0) || rate.size() < blocks) return;
  const double block_s = static_cast<double>(rate.size() / blocks) / rate_hz;
  std::array<double, 4> c{};
  double others = 0.0;  // the other terms' Allan variance at the block length
  for (NoiseTerm t : {NoiseTerm::quantisation, NoiseTerm::angle_random_walk, NoiseTerm::bias_instability}) {
    const TermEstimate& e = fit.term(t);
    if (!e.included) continue;
    const double coefficient = avar_coefficient(t, e.value);
    c[static_cast<std::size_t>(*noise_type(t))] = coefficient;
    others += coefficient * std::pow(block_s, noise_term_power(t));
  }
  c[3] = avar_coefficient(NoiseTerm::rate_random_walk, start);
  if (c[3] * block_s >= others) return;
  const WalkEstimate w = reml_random_walk(rate, rate_hz, c, blocks);
  if (!w.ok) return;
  const double value = term_value(NoiseTerm::rate_random_walk, w.walk_coefficient);
  if (walk.included) {
    walk.value = value;
    walk.relative_se = w.relative_se;
    walk.ci_low = std::min(walk.ci_low, term_value(NoiseTerm::rate_random_walk, w.walk_coefficient * std::exp(-z * w.relative_se)));
    const double high = term_value(NoiseTerm::rate_random_walk, w.walk_coefficient * std::exp(z * w.relative_se));
    if (std::isfinite(high)) walk.ci_high = std::max(walk.ci_high, high);
  } else {
    // The fit's bound stands: a walk the data do not show has a REML value
    // near 0 whose log-normal interval says nothing (a relative standard
    // error of hundreds).
    walk.value_if_present = value;
    walk.relative_se = w.relative_se;
    walk.upper_bound = std::max(walk.upper_bound, value);
  }
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

NoiseFit fit_noise_terms(std::span<const AllanPoint> points, std::size_t samples, double rate_hz,
                         const AllanOptions& options, std::span<const double> rate) {
  Problem pr;
  const double tau0 = 1.0 / rate_hz;
  const std::vector<std::size_t> fit_sizes = allan_cluster_sizes(samples, options.fit_points_per_decade);
  // The Hadamard points: from hadamard_decades below the longest (n / 3).
  const double hadamard_from_m = static_cast<double>(samples / 3) * std::pow(10.0, -options.hadamard_decades);
  std::vector<VarianceEstimate> estimates;
  std::vector<double> values;
  std::vector<double> taus;
  for (const AllanPoint& ap : points) {
    if (ap.m < 1 || 2 * ap.m > samples || !std::binary_search(fit_sizes.begin(), fit_sizes.end(), ap.m)) continue;
    // The longest cluster times hold one or two clusters: their estimate is
    // chi-square with fewer than 2 EDF, whose logarithm has a tail to minus
    // infinity (a pure random walk gives 0.1 % of its Allan variance there
    // in one record of forty) that no normal approximation carries.
    if (ap.adev > 0.0 && std::isfinite(ap.adev) &&
        overlapping_avar_edf(PowerLawNoise::random_walk_rate, ap.m, samples) >= options.min_edf) {
      estimates.push_back({ap.m, 2});
      values.push_back(ap.adev * ap.adev);
      taus.push_back(ap.tau_s);
    }
    if (options.hadamard_decades > 0.0 && ap.hdev > 0.0 && std::isfinite(ap.hdev) && 3 * ap.m <= samples &&
        static_cast<double>(ap.m) >= hadamard_from_m) {
      // The same EDF cut, from the estimate's own variance under a random walk.
      const VarianceEstimate h{ap.m, 3};
      const AvarCovariance single(std::span<const VarianceEstimate>(&h, 1), samples, tau0);
      const double mean = single.expected(0, 3);
      const double edf = 2.0 * mean * mean / single.covariance({0.0, 0.0, 0.0, 1.0})(0, 0);
      if (edf >= options.min_edf) {
        estimates.push_back(h);
        values.push_back(ap.hdev * ap.hdev);
        taus.push_back(ap.tau_s);
      }
    }
  }
  NoiseFit out;
  if (estimates.size() < 3) return out;
  pr.covariance.emplace(estimates, samples, tau0);
  std::vector<double> logs;
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    Point p;
    p.estimate = values[i];
    for (NoiseTerm t : kAllNoiseTerms) {
      const auto j = static_cast<std::size_t>(t);
      const auto type = noise_type(t);
      // The ramp: R^2 tau^2 / 2 in the Allan variance, nothing in the Hadamard.
      p.basis[j] = type ? pr.covariance->expected(i, static_cast<int>(*type))
                        : (estimates[i].differences == 2 ? taus[i] * taus[i] : 0.0);
    }
    pr.points.push_back(p);
    logs.push_back(std::log(p.estimate));
  }
  pr.log_estimate = Eigen::Map<const Eigen::VectorXd>(logs.data(), static_cast<Eigen::Index>(logs.size()));
  const auto count = static_cast<Eigen::Index>(taus.size());
  pr.discrepancy.resize(count, count);
  const double d2 = options.model_discrepancy * options.model_discrepancy;
  for (Eigen::Index i = 0; i < count; ++i) {
    for (Eigen::Index j = 0; j < count; ++j) {
      const auto ui = static_cast<std::size_t>(i);
      const auto uj = static_cast<std::size_t>(j);
      const double distance = std::fabs(std::log10(taus[ui] / taus[uj]));
      const double kinds = estimates[ui].differences == estimates[uj].differences ? 1.0 : options.discrepancy_correlation;
      pr.discrepancy(i, j) = d2 * kinds * std::exp(-distance / kDiscrepancyDecades);
    }
  }
  std::vector<SubsetFit> fits;
  std::vector<double> criteria;
  for (unsigned mask = 1; mask < (1u << kNoiseTerms); ++mask) {
    std::vector<std::size_t> terms;
    for (std::size_t j = 0; j < kNoiseTerms; ++j) {
      if ((mask >> j) & 1u) terms.push_back(j);
    }
    // The ramp alone has no sampling noise to weigh the points by.
    if (terms.size() == 1 && terms[0] == static_cast<std::size_t>(NoiseTerm::rate_ramp)) continue;
    SubsetFit f = fit_subset(pr, terms);
    ++out.models_compared;
    if (!f.ok) continue;
    criteria.push_back(f.minus_two_log_l + options.term_penalty * static_cast<double>(terms.size()));
    fits.push_back(std::move(f));
  }
  if (fits.empty()) return out;
  const auto best = static_cast<std::size_t>(std::min_element(criteria.begin(), criteria.end()) - criteria.begin());
  out.valid = true;
  out.log_likelihood = -0.5 * fits[best].minus_two_log_l;
  out.criterion = criteria[best];
  const double z = std::sqrt(chi_square_quantile(options.confidence, 1.0));
  auto has = [](const SubsetFit& f, std::size_t j) { return std::find(f.terms.begin(), f.terms.end(), j) != f.terms.end(); };
  // The term's coefficient, its relative standard error and interval in one fit.
  auto interval = [&](const SubsetFit& f, std::size_t j, TermEstimate& e) {
    const auto k = static_cast<Eigen::Index>(std::find(f.terms.begin(), f.terms.end(), j) - f.terms.begin());
    const auto term = kAllNoiseTerms[j];
    const double c = f.c[j];
    e.relative_se = std::sqrt(std::max(0.0, f.log_covariance(k, k)));
    e.value = term_value(term, c);
    e.ci_low = term_value(term, c * std::exp(-z * e.relative_se));
    e.ci_high = term_value(term, c * std::exp(z * e.relative_se));
  };
  // Models within the penalty of the best are not told apart by the data:
  // a term's interval spans its intervals in all of them, so a choice the
  // record cannot make (a ramp or a random walk at the longest tau, say)
  // widens the interval instead of hiding in it.
  std::vector<std::size_t> plausible;
  for (std::size_t f = 0; f < fits.size(); ++f) {
    if (criteria[f] - criteria[best] <= options.term_penalty) plausible.push_back(f);
  }
  for (std::size_t j = 0; j < kNoiseTerms; ++j) {
    double without = std::numeric_limits<double>::infinity();
    std::optional<std::size_t> best_with;
    for (std::size_t f = 0; f < fits.size(); ++f) {
      if (!has(fits[f], j)) {
        without = std::min(without, criteria[f]);
      } else if (!best_with || criteria[f] < criteria[*best_with]) {
        best_with = f;
      }
    }
    TermEstimate& e = out.terms[j];
    if (!best_with) continue;
    TermEstimate widest;
    interval(fits[*best_with], j, widest);
    for (std::size_t f : plausible) {
      if (!has(fits[f], j)) continue;
      TermEstimate other;
      interval(fits[f], j, other);
      widest.ci_low = std::min(widest.ci_low, other.ci_low);
      widest.ci_high = std::max(widest.ci_high, other.ci_high);
    }
    if (has(fits[best], j) && without - criteria[best] > options.term_penalty) {
      e.included = true;
      interval(fits[best], j, e);
      e.ci_low = std::min(e.ci_low, widest.ci_low);
      e.ci_high = std::max(e.ci_high, widest.ci_high);
    } else {
      e.upper_bound = widest.ci_high;
      e.value_if_present = widest.value;
      e.relative_se = widest.relative_se;
    }
  }
  if (options.walk_blocks > 0 && rate.size() == samples) {
    refine_random_walk(rate, rate_hz, options.walk_blocks, z, out);
  }
  // A rate random walk leaves a trend of its own in a record of length T: its
  // least-squares slope has standard deviation K sqrt(6 / (5 T)), which the
  // Allan variance cannot tell from a ramp, and the Hadamard points only as
  // far as their few long clusters allow (the ramp's Fisher interval alone
  // was too narrow: standardised errors with mean square 5.8, docs/ALLAN.md).
  // The ramp's interval (or bound) takes the trend in, with K at the top of
  // its interval (or its bound).
  TermEstimate& ramp = out.terms[static_cast<std::size_t>(NoiseTerm::rate_ramp)];
  const TermEstimate& walk = out.terms[static_cast<std::size_t>(NoiseTerm::rate_random_walk)];
  const double k_high = walk.included ? walk.ci_high : walk.upper_bound;
  const double record_s = static_cast<double>(samples) / rate_hz;
  const double trend_sd = k_high * std::sqrt(6.0 / (5.0 * record_s));
  if (ramp.included && trend_sd > 0.0) {
    const double fit_sd = 0.5 * ramp.relative_se * ramp.value;  // R ~ sqrt(c)
    const double sd = std::hypot(fit_sd, trend_sd);
    ramp.ci_low = std::min(ramp.ci_low, std::max(0.0, ramp.value - z * sd));
    ramp.ci_high = std::max(ramp.ci_high, ramp.value + z * sd);
  } else if (!ramp.included && trend_sd > 0.0) {
    ramp.upper_bound = std::max(ramp.upper_bound, z * trend_sd);
  }
  return out;
}

}  // namespace gyrotc::stats
