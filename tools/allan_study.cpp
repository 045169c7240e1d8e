// The coverage study of `gyrotc allan` (issue 20): synthetic rate records of
// known noise (model/rate_noise.hpp: each IEEE 952 term alone and combined),
// analysed as the command analyses a record; for every term of the truth
// the median relative error over the seeds, how often the reported interval
// covers the truth, and how often a term absent from the truth is reported.
// Results: docs/ALLAN.md.
//
//   allan_study                          seeds 1..50, 3 h at 100 Hz, every record type
//   allan_study --seeds 1001:1050 --calibrate
//                                        the mean square of the standardised
//                                        errors per term (1 when the reported
//                                        standard errors are right)
//   allan_study --hours 1 --types white_rrw,combined --out table.md
//   allan_study --bound                  the smallest median error any unbiased
//                                        estimator can reach on each record
//                                        (Cramer-Rao, from the record's own
//                                        second differences; no seeds run)
//
// The term penalty was chosen on seeds 1001..1050; the table in
// docs/ALLAN.md is made on seeds 1..50.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gyrotc/algorithms/model/rate_noise.hpp"
#include "gyrotc/algorithms/stats/allan.hpp"
#include "gyrotc/algorithms/stats/allan_covariance.hpp"

#include <Eigen/Dense>

namespace {

using gyrotc::model::RateNoise;
using gyrotc::stats::NoiseTerm;
namespace stats = gyrotc::stats;

// The record (ARW 0.6 deg/sqrt(h), RRW 43.2 deg/h/sqrt(h)) and its
// companions, in deg/s units.
constexpr double kArw = 0.6 / 60.0;             // deg/sqrt(s)
constexpr double kRrw = 43.2 / 3600.0 / 60.0;   // deg/s/sqrt(s)
constexpr double kBias = 10.0 / 3600.0;         // deg/s (10 deg/h)
constexpr double kQuant = 2e-3;                 // deg (7.2 arcsec)
constexpr double kRamp = 1e-5;                  // deg/s^2 (129.6 deg/h per hour)

struct RecordType {
  std::string name;
  std::string what;
  RateNoise noise;
};

std::vector<RecordType> record_types() {
  std::vector<RecordType> t;
  t.push_back({"white", "angle random walk alone", {0.0, kArw, 0.0, 0.0, 0.0}});
  t.push_back({"rrw", "rate random walk alone", {0.0, 0.0, 0.0, kRrw, 0.0}});
  t.push_back({"flicker", "bias instability (Kasdin 1/f) alone", {0.0, 0.0, kBias, 0.0, 0.0}});
  t.push_back({"quantisation", "angle quantisation alone", {kQuant, 0.0, 0.0, 0.0, 0.0}});
  t.push_back({"ramp", "rate ramp with angle random walk", {0.0, kArw, 0.0, 0.0, kRamp}});
  t.push_back({"white_rrw", "issue 20's record: ARW + RRW", {0.0, kArw, 0.0, kRrw, 0.0}});
  t.push_back({"white_flicker_rrw", "ARW + bias instability + RRW", {0.0, kArw, kBias, kRrw, 0.0}});
  t.push_back({"combined", "all five terms", {kQuant, kArw, kBias, kRrw, kRamp}});
  return t;
}

double truth(const RateNoise& n, NoiseTerm t) {
  switch (t) {
    case NoiseTerm::quantisation: return n.quantisation;
    case NoiseTerm::angle_random_walk: return n.arw;
    case NoiseTerm::bias_instability: return n.bias_instability;
    case NoiseTerm::rate_random_walk: return n.rrw;
    case NoiseTerm::rate_ramp: return std::fabs(n.ramp);
  }
  return 0.0;
}

struct Tally {
  std::vector<double> relative_error;  // |estimate - truth| / truth, terms not resolved count as 1
  std::vector<double> if_present_error;  // the same, a term not resolved scored at its value if present
  std::vector<double> standardised;    // (ln c_est - ln c_true) / relative SE, for --calibrate
  int covered = 0;
  int present = 0;
  int missed = 0;      // a true term not resolved (its upper bound is checked instead)
  int spurious = 0;    // an absent term reported
  int absent = 0;
};

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

struct Args {
  std::uint64_t first_seed = 1;
  std::uint64_t last_seed = 50;
  double hours = 3.0;
  double rate_hz = 100.0;
  stats::AllanOptions options;
  bool calibrate = false;
  bool bound = false;
  std::size_t bound_points = 2000;
  std::vector<std::string> types;
  std::string out;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr, "allan_study: %s\n", why);
  std::fprintf(stderr,
               "usage: allan_study [--seeds A:B] [--hours H] [--rate-hz F] [--penalty P] [--discrepancy D] [--min-edf E]\n"
               "                   [--hadamard-decades H] [--discrepancy-correlation C] [--walk-blocks B]\n"
               "                   [--types a,b,...] [--calibrate] [--bound [--bound-points P]] [--out FILE.md]\n");
  std::exit(2);
}

double number(const char* text, const char* option) {
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v)) usage((std::string(option) + ": not a number").c_str());
  return v;
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](const char* option) {
      if (i + 1 >= argc) usage((std::string(option) + " needs a value").c_str());
      return argv[++i];
    };
    if (arg == "--seeds") {
      const std::string s = value("--seeds");
      const auto colon = s.find(':');
      if (colon == std::string::npos) usage("--seeds: expected FIRST:LAST");
      a.first_seed = static_cast<std::uint64_t>(number(s.substr(0, colon).c_str(), "--seeds"));
      a.last_seed = static_cast<std::uint64_t>(number(s.substr(colon + 1).c_str(), "--seeds"));
      if (a.last_seed < a.first_seed) usage("--seeds: LAST < FIRST");
    } else if (arg == "--hours") {
      a.hours = number(value("--hours"), "--hours");
    } else if (arg == "--rate-hz") {
      a.rate_hz = number(value("--rate-hz"), "--rate-hz");
    } else if (arg == "--discrepancy") {
      a.options.model_discrepancy = number(value("--discrepancy"), "--discrepancy");
    } else if (arg == "--min-edf") {
      a.options.min_edf = number(value("--min-edf"), "--min-edf");
    } else if (arg == "--hadamard-decades") {
      a.options.hadamard_decades = number(value("--hadamard-decades"), "--hadamard-decades");
    } else if (arg == "--discrepancy-correlation") {
      a.options.discrepancy_correlation = number(value("--discrepancy-correlation"), "--discrepancy-correlation");
    } else if (arg == "--walk-blocks") {
      const double v = number(value("--walk-blocks"), "--walk-blocks");
      if (!(v == 0.0 || v >= 10.0)) usage("--walk-blocks: 0 (off) or at least 10");
      a.options.walk_blocks = static_cast<std::size_t>(v);
    } else if (arg == "--penalty") {
      a.options.term_penalty = number(value("--penalty"), "--penalty");
    } else if (arg == "--types") {
      std::stringstream list(value("--types"));
      std::string t;
      while (std::getline(list, t, ',')) a.types.push_back(t);
    } else if (arg == "--bound") {
      a.bound = true;
    } else if (arg == "--bound-points") {
      a.bound_points = static_cast<std::size_t>(number(value("--bound-points"), "--bound-points"));
      if (a.bound_points < 10) usage("--bound-points: at least 10");
    } else if (arg == "--calibrate") {
      a.calibrate = true;
    } else if (arg == "--out") {
      a.out = value("--out");
    } else {
      usage(("unknown option " + arg).c_str());
    }
  }
  if (!(a.hours > 0.0) || !(a.rate_hz > 0.0)) usage("--hours and --rate-hz must be positive");
  if (!(a.options.hadamard_decades >= 0.0)) usage("--hadamard-decades must be >= 0");
  if (!(a.options.discrepancy_correlation >= 0.0 && a.options.discrepancy_correlation <= 1.0)) {
    usage("--discrepancy-correlation must lie in [0, 1]");
  }
  return a;
}

// The median of |X - 1| for X log-normal with sigma s: the x with
// P(ln(1 - x) < s Z < ln(1 + x)) = 1/2.
double lognormal_median_error(double s) {
  auto phi = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  double lo = 0.0;
  double hi = 1.0;
  for (int i = 0; i < 60; ++i) {
    const double x = 0.5 * (lo + hi);
    const double p = phi(std::log1p(x) / s) - (x < 1.0 ? phi(std::log1p(-x) / s) : 0.0);
    (p < 0.5 ? lo : hi) = x;
  }
  return 0.5 * (lo + hi);
}

// Cramer-Rao bound for the long-tau terms (B, K, R) of one record type: the
// Fisher information of its non-overlapped Allan second differences at a
// stride m of about samples / points (Gaussian, covariance sum_j c_j S_j with
// S_j Toeplitz from difference_covariance; the ramp a common mean
// R tau / sqrt 2), for the ln of each term's value, B, K and R estimated
// together. Q and N are taken as known (the short clusters pin them; at the
// stride they would only be confused with each other): knowing more can
// only lower the bound, so it stays a bound.
std::string information_bound(const RecordType& type, std::size_t samples, double rate_hz, std::size_t points) {
  const double tau0 = 1.0 / rate_hz;
  const std::size_t m = std::max<std::size_t>(1, samples / (points + 1));
  const auto n = static_cast<Eigen::Index>(samples / m - 1);
  const stats::VarianceEstimate e{m, 2};
  std::vector<Eigen::MatrixXd> parts;  // of the estimated terms
  std::vector<NoiseTerm> random;
  Eigen::MatrixXd sigma = Eigen::MatrixXd::Zero(n, n);
  std::vector<std::array<double, 4>> lags(static_cast<std::size_t>(n));
  for (Eigen::Index h = 0; h < n; ++h) {
    lags[static_cast<std::size_t>(h)] = stats::difference_covariance(e, e, static_cast<double>(h * static_cast<Eigen::Index>(m)), tau0);
  }
  for (NoiseTerm t : {NoiseTerm::quantisation, NoiseTerm::angle_random_walk, NoiseTerm::bias_instability,
                      NoiseTerm::rate_random_walk}) {
    if (!(truth(type.noise, t) > 0.0)) continue;
    const double c = stats::avar_coefficient(t, truth(type.noise, t));
    const auto j = static_cast<std::size_t>(t);
    Eigen::MatrixXd s(n, n);
    for (Eigen::Index k = 0; k < n; ++k) {
      for (Eigen::Index l = 0; l < n; ++l) s(k, l) = c * lags[static_cast<std::size_t>(std::abs(k - l))][j];
    }
    sigma += s;
    if (stats::noise_term_power(t) >= 0) {
      random.push_back(t);
      parts.push_back(std::move(s));
    }
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(sigma);
  std::vector<Eigen::MatrixXd> solved;
  for (const Eigen::MatrixXd& s : parts) solved.push_back(llt.solve(s));
  const bool ramp = type.noise.ramp != 0.0;
  const auto p = static_cast<Eigen::Index>(random.size() + (ramp ? 1 : 0));
  if (p == 0) return {};
  Eigen::MatrixXd fisher = Eigen::MatrixXd::Zero(p, p);
  for (std::size_t a = 0; a < solved.size(); ++a) {
    for (std::size_t b = 0; b < solved.size(); ++b) {
      // tr(A B) without the product: sum of A .* B^T.
      fisher(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)) = 0.5 * solved[a].cwiseProduct(solved[b].transpose()).sum();
    }
  }
  if (ramp) {
    const double tau = static_cast<double>(m) * tau0;
    const Eigen::VectorXd mu = Eigen::VectorXd::Constant(n, std::fabs(type.noise.ramp) * tau / std::sqrt(2.0));
    fisher(p - 1, p - 1) = 0.25 * mu.dot(llt.solve(mu));  // per ln c_R = 2 ln R
  }
  const Eigen::MatrixXd inverse = fisher.inverse();
  std::string rows;
  char line[256];
  for (Eigen::Index a = 0; a < p; ++a) {
    const NoiseTerm t = a < static_cast<Eigen::Index>(random.size()) ? random[static_cast<std::size_t>(a)] : NoiseTerm::rate_ramp;
    const double sd_ln_value = 0.5 * std::sqrt(inverse(a, a));
    std::snprintf(line, sizeof line, "| %s | %s | %.4g | %.3f | %.1f %% |\n", type.name.c_str(),
                  std::string(stats::noise_term_name(t)).c_str(), truth(type.noise, t), sd_ln_value,
                  100.0 * lognormal_median_error(sd_ln_value));
    rows += line;
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  std::vector<RecordType> types;
  for (const RecordType& t : record_types()) {
    if (args.types.empty() || std::find(args.types.begin(), args.types.end(), t.name) != args.types.end()) {
      types.push_back(t);
    }
  }
  if (types.empty()) usage("--types: no known record type (white, rrw, flicker, quantisation, ramp, white_rrw, white_flicker_rrw, combined)");
  if (!args.out.empty()) {
    std::ofstream probe(args.out, std::ios::app);
    if (!probe) usage(("--out " + args.out + ": cannot write").c_str());
  }
  const auto samples = static_cast<std::size_t>(std::llround(args.hours * 3600.0 * args.rate_hz));
  if (args.bound) {
    char head[160];
    std::snprintf(head, sizeof head, "Cramer-Rao bound for B, K and R (Q and N known), %g h at %g Hz, from about %zu non-overlapped second differences",
                  args.hours, args.rate_hz, args.bound_points);
    std::string table = std::string(head) + ": the least standard deviation of ln(estimate) of any "
                        "unbiased estimator that always reports every term of the truth, and the median error it "
                        "implies.\n\n| record | term | truth | sd ln | smallest median error |\n|---|---|---|---|---|\n";
    for (const RecordType& type : types) {
      std::fprintf(stderr, "%s...\n", type.name.c_str());
      table += information_bound(type, samples, args.rate_hz, args.bound_points);
    }
    std::fputs(table.c_str(), stdout);
    if (!args.out.empty()) {
      std::ofstream out(args.out);
      out << table;
      if (!out) return 1;
    }
    return 0;
  }
  const std::uint64_t seeds = args.last_seed - args.first_seed + 1;
  const auto start = std::chrono::steady_clock::now();
  std::string table;
  char line[512];
  std::snprintf(line, sizeof line,
                "Seeds %llu..%llu, %g h at %g Hz (%zu samples), %.0f %% intervals, term penalty %g, model "
                "discrepancy %g (Allan-Hadamard correlation %g), points with EDF >= %g, Hadamard points over %g decades, "
                "random walk by REML on %zu block means (0: off).\n\n",
                static_cast<unsigned long long>(args.first_seed), static_cast<unsigned long long>(args.last_seed),
                args.hours, args.rate_hz, samples, 100.0 * args.options.confidence, args.options.term_penalty,
                args.options.model_discrepancy, args.options.discrepancy_correlation, args.options.min_edf,
                args.options.hadamard_decades, args.options.walk_blocks);
  table += line;
  table += "| record | term | truth | median error | median error, value if present | interval (or bound) covers truth | resolved |\n";
  table += "|---|---|---|---|---|---|---|\n";
  std::vector<std::vector<double>> pooled(stats::kNoiseTerms);
  std::size_t done = 0;
  for (const RecordType& type : types) {
    std::vector<Tally> tally(stats::kNoiseTerms);
    for (std::uint64_t seed = args.first_seed; seed <= args.last_seed; ++seed) {
      const std::vector<double> y = gyrotc::model::generate_rate_noise(type.noise, args.rate_hz, samples, seed);
      const stats::AllanResult r = stats::allan_deviation(y, args.rate_hz, args.options);
      for (NoiseTerm t : stats::kAllNoiseTerms) {
        Tally& k = tally[static_cast<std::size_t>(t)];
        const double want = truth(type.noise, t);
        const stats::TermEstimate& e = r.fit.term(t);
        if (want > 0.0) {
          ++k.present;
          if (!e.included) {
            // Not resolved: the reported upper bound must hold the truth.
            ++k.missed;
            k.relative_error.push_back(1.0);
            k.if_present_error.push_back(e.value_if_present > 0.0 ? std::fabs(e.value_if_present - want) / want : 1.0);
            if (want <= e.upper_bound) ++k.covered;
            continue;
          }
          k.relative_error.push_back(std::fabs(e.value - want) / want);
          k.if_present_error.push_back(k.relative_error.back());
          if (e.ci_low <= want && want <= e.ci_high) ++k.covered;
          if (e.relative_se > 0.0) {
            const double z = (std::log(stats::avar_coefficient(t, e.value)) - std::log(stats::avar_coefficient(t, want))) /
                             e.relative_se;
            k.standardised.push_back(z);
            pooled[static_cast<std::size_t>(t)].push_back(z);
          }
        } else {
          ++k.absent;
          if (e.included) ++k.spurious;
        }
      }
      ++done;
      std::fprintf(stderr, "\r%zu / %llu records", done, static_cast<unsigned long long>(seeds * types.size()));
    }
    for (NoiseTerm t : stats::kAllNoiseTerms) {
      const Tally& k = tally[static_cast<std::size_t>(t)];
      const std::string name(stats::noise_term_name(t));
      if (k.present > 0) {
        std::snprintf(line, sizeof line, "| %s | %s | %.4g | %.1f %% | %.1f %% | %d / %d (%.0f %%) | %d / %d |\n",
                      type.name.c_str(), name.c_str(), truth(type.noise, t), 100.0 * median(k.relative_error),
                      100.0 * median(k.if_present_error), k.covered, k.present,
                      100.0 * k.covered / k.present, k.present - k.missed, k.present);
        table += line;
      } else if (k.spurious > 0) {
        std::snprintf(line, sizeof line, "| %s | %s (absent) | 0 | - | - | - | %d / %d reported |\n", type.name.c_str(),
                      name.c_str(), k.spurious, k.absent);
        table += line;
      }
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "\r%zu records in %.0f s\n", done, wall);
  table += "\nMedian error: a term not resolved counts as a 100 % error; value if present: it is scored at the value\n"
           "`allan` gives it if present (its value in the best model that has it). A term not resolved counts as\n"
           "covered when its upper bound holds the truth.\n"
           "Absent terms not listed were never reported. Truth in deg/s units: Q deg, N deg/sqrt(s), B deg/s, "
           "K deg/s/sqrt(s), R deg/s^2.\n";
  if (args.calibrate) {
    table += "\nStandardised errors (ln estimate - ln truth) / reported standard error of each term's\n"
             "Allan-variance coefficient: mean square about the truth (1 when the intervals are right).\n\n";
    table += "| term | records | variance |\n|---|---|---|\n";
    for (NoiseTerm t : stats::kAllNoiseTerms) {
      const auto& z = pooled[static_cast<std::size_t>(t)];
      if (z.size() < 2) continue;
      double mean = 0.0;
      for (double v : z) mean += v;
      mean /= static_cast<double>(z.size());
      double var = 0.0;
      for (double v : z) var += v * v;  // about the truth, not the mean: bias counts too
      var /= static_cast<double>(z.size());
      std::snprintf(line, sizeof line, "| %s | %zu | %.2f (mean %.2f) |\n", std::string(stats::noise_term_name(t)).c_str(),
                    z.size(), var, mean);
      table += line;
    }
  }
  std::fputs(table.c_str(), stdout);
  if (!args.out.empty()) {
    std::ofstream out(args.out);
    out << table;
    if (!out) {
      std::fprintf(stderr, "allan_study: %s: write failed\n", args.out.c_str());
      return 1;
    }
  }
  return 0;
}
