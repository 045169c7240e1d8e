// The long statistical sweep of `gyrotc identify` (issue 8), kept out of the
// test suite: synthetic records with known hidden effects (record_generator)
// across effect parameters, noise (white, AR(1), DS18B20 quantisation) and
// chamber profiles, then the confusion matrix and the false-positive rate
// over >= 100 null records. The decision thresholds are chosen on training
// seeds (1..) among a few candidate settings, then reported on test seeds
// (100001..) that played no part in choosing them. Results: docs/IDENTIFY.md.
//
//   identify_sweep                     full sweep (a few minutes, Release)
//   identify_sweep --quick             fewer seeds
//   identify_sweep --write-record F --effect thermal_lag [--hours 24] [--seed 7]
//                                      write one synthetic record as CSV

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/record_generator.hpp"
#include "gyrotc/algorithms/identify/series_identify.hpp"

namespace {

using namespace gyrotc::identify;
namespace model = gyrotc::model;

struct Scenario {
  std::string name;
  std::string expected;
  SeriesTarget target = SeriesTarget::gyro_mv;
  RecordSpec spec;
};

const char* profile_name(ChamberProfile p) {
  switch (p) {
    case ChamberProfile::staircase: return "staircase";
    case ChamberProfile::up_down_ramps: return "up-down";
    case ChamberProfile::random_steps: return "random-steps";
  }
  return "?";
}

std::vector<Scenario> null_scenarios() {
  std::vector<Scenario> out;
  for (auto p : {ChamberProfile::up_down_ramps, ChamberProfile::random_steps, ChamberProfile::staircase}) {
    for (auto noise : {NoiseKind::white, NoiseKind::ar1}) {
      Scenario s;
      s.spec.profile = p;
      s.spec.noise = noise;
      s.name = std::string("null ") + profile_name(p) + (noise == NoiseKind::ar1 ? " ar1" : " white");
      s.expected = "none";
      out.push_back(s);
    }
  }
  Scenario t;
  t.name = "null sensor_c";
  t.expected = "none";
  t.target = SeriesTarget::sensor_c;
  t.spec.profile = ChamberProfile::random_steps;
  t.spec.tec_step_a = 1.5;
  out.push_back(t);
  return out;
}

std::vector<Scenario> effect_scenarios() {
  std::vector<Scenario> out;
  const auto add = [&](const std::string& name, const std::string& expected, ChamberProfile p, auto set) {
    Scenario s;
    s.name = name + " / " + profile_name(p);
    s.expected = expected;
    s.spec.profile = p;
    set(s);
    out.push_back(s);
  };
  for (auto p : {ChamberProfile::up_down_ramps, ChamberProfile::random_steps}) {
    for (double tau : {60.0, 300.0}) {
      add("thermal_lag tau " + std::to_string(static_cast<int>(tau)), "thermal_lag", p,
          [&](Scenario& s) { s.spec.effects.thermal_lag = model::ThermalLagEffect{tau}; });
    }
    for (double k : {30.0, 80.0}) {
      add("rate_sensitivity k " + std::to_string(static_cast<int>(k)), "rate_sensitivity", p,
          [&](Scenario& s) { s.spec.effects.rate_sensitivity = model::RateSensitivityEffect{k}; });
    }
    add("ramp_hysteresis h 0.5", "ramp_hysteresis", p,
        [&](Scenario& s) { s.spec.effects.ramp_hysteresis = model::RampHysteresisEffect{0.5, 0.002}; });
  }
  for (auto p : {ChamberProfile::up_down_ramps, ChamberProfile::random_steps, ChamberProfile::staircase}) {
    add("warm_up 1 mV 600 s", "warm_up", p,
        [&](Scenario& s) { s.spec.effects.warm_up = model::WarmUpEffect{1.0, 600.0}; });
    add("linear_drift 0.1 mV/h ar1", "linear_drift", p, [&](Scenario& s) {
      s.spec.effects.linear_drift = model::LinearDriftEffect{0.1};
      s.spec.noise = NoiseKind::ar1;
    });
  }
  add("thermal_lag 150 s (not claimable)", "none", ChamberProfile::staircase,
      [&](Scenario& s) { s.spec.effects.thermal_lag = model::ThermalLagEffect{150.0}; });
  add("thermal_lag 150 + warm_up", "thermal_lag+warm_up", ChamberProfile::up_down_ramps, [&](Scenario& s) {
    s.spec.effects.thermal_lag = model::ThermalLagEffect{150.0};
    s.spec.effects.warm_up = model::WarmUpEffect{2.0, 600.0};
  });
  add("lag 30 s, narrow 22..34 C, 1 mV noise", "ambiguous:thermal_lag+rate_sensitivity",
      ChamberProfile::up_down_ramps, [&](Scenario& s) {
        s.spec.low_c = 22.0;
        s.spec.high_c = 34.0;
        s.spec.noise_mv = 1.0;
        s.spec.effects.thermal_lag = model::ThermalLagEffect{30.0};
      });
  add("tec_joule_heating 0.5 ohm", "tec_joule_heating", ChamberProfile::random_steps, [&](Scenario& s) {
    s.target = SeriesTarget::sensor_c;
    s.spec.tec_step_a = 1.5;
    s.spec.effects.tec_joule_heating = model::TecJouleHeatingEffect{0.5};
  });
  return out;
}

// Order-insensitive comparison of verdicts joined by '+'.
std::string canonical(std::string v) {
  const std::string prefix = v.rfind("ambiguous:", 0) == 0 ? "ambiguous:" : "";
  v = v.substr(prefix.size());
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start <= v.size()) {
    const std::size_t plus = v.find('+', start);
    parts.push_back(v.substr(start, plus == std::string::npos ? std::string::npos : plus - start));
    if (plus == std::string::npos) break;
    start = plus + 1;
  }
  std::sort(parts.begin(), parts.end());
  std::string out = prefix;
  for (std::size_t i = 0; i < parts.size(); ++i) out += (i ? "+" : "") + parts[i];
  return out;
}

struct Tally {
  std::map<std::string, std::map<std::string, int>> matrix;  // expected -> got -> count
  int null_records = 0;
  int null_false_positives = 0;
  int records = 0;
  int correct = 0;
};

Tally run(const std::vector<Scenario>& scenarios, std::uint64_t first_seed, int seeds, const Criteria& c,
          bool verbose) {
  Tally t;
  for (const auto& sc : scenarios) {
    for (int k = 0; k < seeds; ++k) {
      RecordSpec spec = sc.spec;
      spec.seed = first_seed + static_cast<std::uint64_t>(k) * 7919u;
      const Identification id = identify_series(generate_record(spec), sc.target, {}, c);
      const std::string got = canonical(id.verdict);
      const std::string expected = canonical(sc.expected);
      ++t.matrix[sc.expected][got];
      ++t.records;
      if (got == expected) ++t.correct;
      if (sc.expected == "none") {
        ++t.null_records;
        if (got != "none") ++t.null_false_positives;
      }
      if (verbose && got != expected) {
        std::printf("  miss: %-45s seed %llu -> %s\n", sc.name.c_str(),
                    static_cast<unsigned long long>(spec.seed), id.verdict.c_str());
      }
    }
  }
  return t;
}

void print_matrix(const Tally& t) {
  std::vector<std::string> columns;
  for (const auto& [expected, row] : t.matrix) {
    for (const auto& [got, n] : row) {
      if (std::find(columns.begin(), columns.end(), got) == columns.end()) columns.push_back(got);
    }
  }
  std::sort(columns.begin(), columns.end());
  std::printf("| expected \\ verdict |");
  for (const auto& c : columns) std::printf(" %s |", c.c_str());
  std::printf("\n|---|");
  for (std::size_t i = 0; i < columns.size(); ++i) std::printf("---|");
  std::printf("\n");
  for (const auto& [expected, row] : t.matrix) {
    std::printf("| %s |", expected.c_str());
    for (const auto& c : columns) {
      const auto it = row.find(c);
      std::printf(" %d |", it == row.end() ? 0 : it->second);
    }
    std::printf("\n");
  }
}

int write_record(int argc, char** argv) {
  std::string path;
  std::string effect = "none";
  double hours = 6.0;
  std::uint64_t seed = 7;
  for (int i = 1; i + 1 < argc; ++i) {
    if (!std::strcmp(argv[i], "--write-record")) path = argv[++i];
    else if (!std::strcmp(argv[i], "--effect")) effect = argv[++i];
    else if (!std::strcmp(argv[i], "--hours")) hours = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--seed")) seed = std::strtoull(argv[++i], nullptr, 10);
  }
  RecordSpec spec;
  spec.duration_s = hours * 3600.0;
  spec.seed = seed;
  if (effect == "thermal_lag") spec.effects.thermal_lag = model::ThermalLagEffect{150.0};
  else if (effect == "rate_sensitivity") spec.effects.rate_sensitivity = model::RateSensitivityEffect{80.0};
  else if (effect == "ramp_hysteresis") spec.effects.ramp_hysteresis = model::RampHysteresisEffect{0.5, 0.002};
  else if (effect == "warm_up") spec.effects.warm_up = model::WarmUpEffect{2.0, 600.0};
  else if (effect == "linear_drift") spec.effects.linear_drift = model::LinearDriftEffect{0.2};
  else if (effect == "tec_joule_heating") {
    spec.profile = ChamberProfile::random_steps;
    spec.tec_step_a = 1.5;
    spec.effects.tec_joule_heating = model::TecJouleHeatingEffect{0.5};
  } else if (effect != "none") {
    std::fprintf(stderr, "identify_sweep: unknown effect '%s'\n", effect.c_str());
    return 2;
  }
  const SeriesRecord r = generate_record(spec);
  std::ofstream out(path);
  out << "time_s,ambient_c,sensor_c,gyro_mv,tec_a\n";
  char line[160];
  for (std::size_t i = 0; i < r.time_s.size(); ++i) {
    std::snprintf(line, sizeof line, "%.1f,%.4f,%.4f,%.4f,%.4f\n", r.time_s[i], r.ambient_c[i], r.sensor_c[i],
                  r.gyro_mv[i], r.tec_a[i]);
    out << line;
  }
  if (!out) {
    std::fprintf(stderr, "identify_sweep: cannot write %s\n", path.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--write-record")) return write_record(argc, argv);
  }
  const bool quick = argc > 1 && !std::strcmp(argv[1], "--quick");
  const auto nulls = null_scenarios();
  const auto effects = effect_scenarios();
  std::vector<Scenario> all = nulls;
  all.insert(all.end(), effects.begin(), effects.end());

  // 1. Choose the thresholds on the training seeds.
  std::vector<Criteria> settings;
  for (double bic : {10.0, 25.0}) {
    for (double amb : {6.0, 15.0, 30.0}) {
      Criteria c;
      c.min_delta_bic = bic;
      c.ambiguous_delta_bic = amb;
      settings.push_back(c);
    }
  }
  const int train_seeds = quick ? 2 : 4;
  std::printf("## Training seeds (1.., %d per scenario): accuracy per setting\n\n", train_seeds);
  std::size_t best = 0;
  double best_score = -1.0;
  for (std::size_t i = 0; i < settings.size(); ++i) {
    const Tally t = run(all, 1, train_seeds, settings[i], false);
    const double fp = static_cast<double>(t.null_false_positives) / t.null_records;
    const double score = static_cast<double>(t.correct) / t.records - fp;  // accuracy, false positives count twice
    std::printf("- min_delta_bic %.0f, ambiguous_delta_bic %.0f: %d/%d correct, %d/%d null false positives\n",
                settings[i].min_delta_bic, settings[i].ambiguous_delta_bic, t.correct, t.records,
                t.null_false_positives, t.null_records);
    if (score >= best_score) {  // settings go from lenient to strict: ties go to the stricter
      best_score = score;
      best = i;
    }
  }
  std::printf("\nChosen: min_delta_bic %.0f, ambiguous_delta_bic %.0f\n\n", settings[best].min_delta_bic,
              settings[best].ambiguous_delta_bic);

  // 2. Report on other seeds: >= 100 null records, every effect scenario.
  const int null_seeds = quick ? 5 : 15;  // 7 null scenarios
  const int effect_seeds = quick ? 2 : 5;
  const auto start = std::chrono::steady_clock::now();
  Tally null_tally = run(nulls, 100001, null_seeds, settings[best], true);
  Tally effect_tally = run(effects, 100001, effect_seeds, settings[best], true);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Tally merged = effect_tally;
  for (const auto& [e, row] : null_tally.matrix) {
    for (const auto& [g, n] : row) merged.matrix[e][g] += n;
  }
  std::printf("\n## Test seeds (100001..): confusion matrix\n\n");
  print_matrix(merged);
  std::printf("\nNull records: %d, false positives: %d (%.1f %%)\n", null_tally.null_records,
              null_tally.null_false_positives, 100.0 * null_tally.null_false_positives / null_tally.null_records);
  std::printf("Effect records: %d, verdict as expected: %d (%.1f %%)\n", effect_tally.records, effect_tally.correct,
              100.0 * effect_tally.correct / effect_tally.records);
  std::printf("Test records: %d in %.1f s\n", null_tally.records + effect_tally.records, elapsed);

  // 3. The speed requirement: a 24 h record at 1 Hz with every candidate.
  RecordSpec day;
  day.duration_s = 24.0 * 3600.0;
  day.effects.thermal_lag = model::ThermalLagEffect{150.0};
  const SeriesRecord record = generate_record(day);
  const auto t0 = std::chrono::steady_clock::now();
  const Identification id = identify_series(record, SeriesTarget::gyro_mv, {}, settings[best]);
  const double day_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("24 h at 1 Hz (%zu rows, thermal_lag hidden): verdict %s in %.2f s\n", record.time_s.size(),
              id.verdict.c_str(), day_s);
  return 0;
}
