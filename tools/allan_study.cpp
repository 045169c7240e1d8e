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
constexpr double kRamp = 1e-5;                  // deg/s^2 (36 deg/h per hour)

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
  std::vector<std::string> types;
  std::string out;
};

[[noreturn]] void usage(const char* why) {
  std::fprintf(stderr, "allan_study: %s\n", why);
  std::fprintf(stderr,
               "usage: allan_study [--seeds A:B] [--hours H] [--rate-hz F] [--penalty P] [--discrepancy D] [--min-edf E]\n"
               "                   [--types a,b,...] [--calibrate] [--out FILE.md]\n");
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
    } else if (arg == "--penalty") {
      a.options.term_penalty = number(value("--penalty"), "--penalty");
    } else if (arg == "--types") {
      std::stringstream list(value("--types"));
      std::string t;
      while (std::getline(list, t, ',')) a.types.push_back(t);
    } else if (arg == "--calibrate") {
      a.calibrate = true;
    } else if (arg == "--out") {
      a.out = value("--out");
    } else {
      usage(("unknown option " + arg).c_str());
    }
  }
  if (!(a.hours > 0.0) || !(a.rate_hz > 0.0)) usage("--hours and --rate-hz must be positive");
  return a;
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
  const std::uint64_t seeds = args.last_seed - args.first_seed + 1;
  const auto start = std::chrono::steady_clock::now();
  std::string table;
  char line[512];
  std::snprintf(line, sizeof line,
                "Seeds %llu..%llu, %g h at %g Hz (%zu samples), %.0f %% intervals, term penalty %g, model "
                "discrepancy %g, points with EDF >= %g.\n\n",
                static_cast<unsigned long long>(args.first_seed), static_cast<unsigned long long>(args.last_seed),
                args.hours, args.rate_hz, samples, 100.0 * args.options.confidence, args.options.term_penalty,
                args.options.model_discrepancy, args.options.min_edf);
  table += line;
  table += "| record | term | truth | median error | interval (or bound) covers truth | resolved |\n";
  table += "|---|---|---|---|---|---|\n";
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
            if (want <= e.upper_bound) ++k.covered;
            continue;
          }
          k.relative_error.push_back(std::fabs(e.value - want) / want);
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
        std::snprintf(line, sizeof line, "| %s | %s | %.4g | %.1f %% | %d / %d (%.0f %%) | %d / %d |\n", type.name.c_str(),
                      name.c_str(), truth(type.noise, t), 100.0 * median(k.relative_error), k.covered, k.present,
                      100.0 * k.covered / k.present, k.present - k.missed, k.present);
        table += line;
      } else if (k.spurious > 0) {
        std::snprintf(line, sizeof line, "| %s | %s (absent) | 0 | - | - | %d / %d reported |\n", type.name.c_str(),
                      name.c_str(), k.spurious, k.absent);
        table += line;
      }
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "\r%zu records in %.0f s\n", done, wall);
  table += "\nA term not resolved counts as a 100 % error, and as covered when its upper bound holds the truth.\n"
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
