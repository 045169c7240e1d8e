#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <string_view>
#include <vector>

// Overlapping Allan deviation (IEEE Std 952-1997, Annex C) of a rate record
// sampled at a constant rate, and the standard noise terms fitted to it with
// their uncertainties: quantisation Q, angle random walk N, bias instability
// B, rate random walk K and rate ramp R.
namespace gyrotc::stats {

// The terms of the Allan variance model (IEEE 952 Annex C.2):
//   AVAR(tau) = 3 Q^2 / tau^2 + N^2 / tau + (2 ln 2 / pi) B^2 + K^2 tau / 3 + R^2 tau^2 / 2.
enum class NoiseTerm { quantisation, angle_random_walk, bias_instability, rate_random_walk, rate_ramp };
inline constexpr std::size_t kNoiseTerms = 5;
inline constexpr std::array<NoiseTerm, kNoiseTerms> kAllNoiseTerms = {
    NoiseTerm::quantisation, NoiseTerm::angle_random_walk, NoiseTerm::bias_instability,
    NoiseTerm::rate_random_walk, NoiseTerm::rate_ramp};

// "quantisation", "angle_random_walk", "bias_instability", "rate_random_walk", "rate_ramp".
std::string_view noise_term_name(NoiseTerm term);
// The power of tau of the term's Allan variance: -2, -1, 0, 1, 2.
int noise_term_power(NoiseTerm term);
// The term's Allan-variance coefficient c (AVAR = c tau^power) for a
// coefficient value (Q, N, B, K or R), and back.
double avar_coefficient(NoiseTerm term, double value);
double term_value(NoiseTerm term, double avar_coefficient);

struct AllanOptions {
  // Cluster times are log-spaced: round(10^(k / points_per_decade)) samples,
  // duplicates dropped. 10 per decade is finer than the octave (3.3 per decade).
  double points_per_decade = 10.0;
  // The fit uses the cluster times of a coarser grid (a subset of the one
  // above): neighbours an octave apart still correlate 0.7-0.95, so the
  // finer grid adds little information and costs O(points^3) per step.
  double fit_points_per_decade = 5.0;
  // Confidence of the reported intervals (of each point and each term).
  double confidence = 0.95;
  // How far a record's Allan variance may depart from the five power laws
  // without the fit chasing it: a relative standard deviation, correlated
  // over half a decade of tau, added to the estimates' own. Real spectra are
  // not exact power laws (filters, the sampling, 1/f noise that is 1/f only
  // over some decades), and estimates with EDF 10^5 would otherwise claim a
  // precision of 0.3 %. 2 % is an assumption, stated in docs/ALLAN.md.
  double model_discrepancy = 0.02;
  // The fit leaves out the cluster times whose estimate would have fewer
  // EDF than this for a random walk of the rate (the fewest of the noise
  // types): the last few, with one or two clusters.
  double min_edf = 2.0;
  // Information criterion: a term is kept when it lowers -2 log L by more
  // than this (6.63 = the 1 % point of chi^2 with one degree of freedom).
  double term_penalty = 6.63;
  // The fit also takes the Hadamard variance over this many decades below
  // its longest cluster time (n / 3): there a rate ramp (which the Hadamard
  // variance does not see) and a rate random walk (which it does) part,
  // where the Allan variance alone confuses them. Below, both variances see
  // the same noise and the Hadamard points add cost, not information.
  // 0: Allan variance only.
  double hadamard_decades = 2.0;
  // Correlation of the model discrepancy between the Allan and the Hadamard
  // estimate at one tau: one spectrum's departure from the power laws shows
  // in both, through filters of different shape (0.9 and 0.5 gave the same
  // coverage on the calibration seeds; 0.9 the smaller errors).
  double discrepancy_correlation = 0.9;
  // The rate random walk's value and interval are refined by REML on the
  // differences of this many block means of the record (allan_walk.hpp):
  // its information lies in the longest spans, where the Allan points are
  // few and correlated. 500 blocks hold all but a few percent of the
  // information (the bound of tools/allan_study --bound next to a bias
  // instability: 14.9 % at 500, 14.2 % at 2000, 14.1 % at 4000) at
  // O(blocks^2) per step.
  // 0: the Allan fit's value.
  std::size_t walk_blocks = 500;
};

struct AllanPoint {
  double tau_s = 0.0;
  std::size_t m = 0;      // cluster size in samples
  double adev = 0.0;      // units of the input rate
  // Overlapping Hadamard deviation at the same tau (third differences of the
  // angle, normalised so that white rate noise gives the Allan value); blind
  // to a rate ramp. 0 where 3 m > n.
  double hdev = 0.0;
  double edf = 0.0;       // equivalent degrees of freedom of the estimate under the fitted noise mixture
  double ci_low = 0.0;    // confidence interval of the deviation (chi-square with edf)
  double ci_high = 0.0;
  double clusters = 0.0;  // n / m
};

// One noise term of the fit.
struct TermEstimate {
  // Resolved: the best model has the term and every model without it is
  // worse by more than the term penalty. Otherwise the term is "not
  // resolved": absent from the record, or not told apart from another term
  // (a rate random walk that a short record shows as flat, say).
  bool included = false;
  double value = 0.0;     // Q (u s), N (u sqrt(s)), B (u), K (u / sqrt(s)), R (u / s); 0 when not included
  // Confidence interval of the value: its interval in the best model,
  // widened to those of every model with the term whose criterion is within
  // the term penalty of the best (the models the data do not tell apart).
  double ci_low = 0.0;
  double ci_high = 0.0;
  // Standard error of the AVAR coefficient / the coefficient: of the value
  // (best model), or of the value if present for a term not resolved.
  double relative_se = 0.0;
  // Not resolved: the upper end of the term's interval over the best-scoring
  // model that has it and those within the penalty of the best (0 when no
  // model with the term could be fitted).
  double upper_bound = 0.0;
  // Not resolved: the term's value in the best-scoring model that has it,
  // what the record says of the term if it is there (a term the data cannot
  // confirm may still be real: a rate random walk beside a bias instability
  // in 3 h is unresolved in about half such records, and this value, not 0,
  // is the better guess of it; the random walk's is refined by REML as
  // fit_noise_terms says). 0 when no model with the term could be fitted.
  double value_if_present = 0.0;
};

struct NoiseFit {
  std::array<TermEstimate, kNoiseTerms> terms{};
  double log_likelihood = 0.0;  // of the chosen model
  double criterion = 0.0;       // -2 log L + penalty per term
  std::size_t models_compared = 0;
  bool valid = false;           // false when no model could be fitted (too few points)

  const TermEstimate& term(NoiseTerm t) const { return terms[static_cast<std::size_t>(t)]; }
  // The model's Allan variance at tau.
  double avar(double tau_s) const;
};

struct AllanResult {
  std::size_t samples = 0;
  double rate_hz = 0.0;
  std::vector<AllanPoint> points;
  NoiseFit fit;
};

// Overlapping Allan deviation at the log-spaced cluster sizes 1 .. n/2 (and
// the Hadamard deviation where 3 m <= n), each in O(n) from the cumulative
// sum (the angle): with theta_k = tau0 * sum of the first k rates, N = n + 1
// angles,
//   AVAR(m tau0) = sum_{k=0}^{N-2m-1} (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2
//                  / (2 (m tau0)^2 (N - 2m))                     (IEEE 952 Eq. C.4)
// The record's mean is removed first: it does not change AVAR and keeps the
// cumulative sum small, so the differences keep their precision.
//
// Then fit_noise_terms (with the record, for the random walk's REML), and
// each point's interval from the chi-square
// distribution with the EDF of the fitted noise mixture at its tau.
//
// Throws std::invalid_argument for fewer than 2 samples, a non-positive or
// non-finite rate_hz, or a non-finite sample.
AllanResult allan_deviation(std::span<const double> rate, double rate_hz, const AllanOptions& options = {});

// Fits the terms to the points of a record of `samples` samples at rate_hz
// over every cluster time: their Allan variances, and their Hadamard
// variances over options.hadamard_decades below n / 3 (a ramp has none; the
// other terms' Hadamard variance is a constant times their Allan variance).
// The logarithms of the estimates are taken as
// jointly normal: each ln(VAR chi^2_nu / nu) with nu its EDF under the
// model's mixture of noise types (mean ln AVAR + psi(nu/2) - ln(nu/2),
// variance psi'(nu/2)), correlated across cluster times as the model's
// covariance of the estimates says (allan_covariance.hpp), plus the model
// discrepancy of the options. Every subset of
// the five terms is fitted by maximum likelihood (Gauss-Newton in the
// logarithms of the coefficients, so they stay positive); the subset with
// the least criterion wins; a term is reported only when the data support
// it against every model without it. Each coefficient's standard error
// comes from the Fisher information; its interval is log-normal. The ramp's
// interval also holds the trend a rate random walk leaves in the record,
// K sqrt(6 / (5 T)) (the Hadamard points tell the two apart only as far as
// their few long clusters allow).
//
// Given the record itself (`rate`, the samples the points came from) and
// options.walk_blocks > 0, the rate random walk's value (or value if
// present) comes from reml_random_walk on the record's block means, under
// the chosen model (its quantisation and white rate held, its bias
// instability estimated beside the walk), where the walk is under half the
// fitted Allan variance at the block length (elsewhere the short clusters
// know it better); its interval then spans both the fit's and the REML
// one. Whether the walk is resolved, and the upper bound of a walk not
// resolved, stay the fit's.
NoiseFit fit_noise_terms(std::span<const AllanPoint> points, std::size_t samples, double rate_hz,
                         const AllanOptions& options = {}, std::span<const double> rate = {});

// EDF of the Allan variance estimate at cluster size m (tau = m tau0) of a
// record of `samples` samples under the fitted mixture of noise types:
// 1/nu = sum_j (share_j^2 / nu_j) over the random terms (the ramp adds no
// estimation variance), each nu_j by Greenhall's algorithm.
double mixture_edf(const NoiseFit& fit, double tau_s, std::size_t m, std::size_t samples);

// The cluster sizes used for n samples: log-spaced, 1 .. n/2.
std::vector<std::size_t> allan_cluster_sizes(std::size_t n, double points_per_decade);

// Unit conversions for a rate in deg/s (N in deg/sqrt(s), K in deg/s/sqrt(s)).
constexpr double arw_deg_per_rt_h(double n_deg_per_rt_s) { return n_deg_per_rt_s * 60.0; }
constexpr double bias_deg_per_h(double b_dps) { return b_dps * 3600.0; }
constexpr double rrw_deg_per_h_per_rt_h(double k_dps_per_rt_s) { return k_dps_per_rt_s * 3600.0 * 60.0; }

}  // namespace gyrotc::stats
