#pragma once

#include <string>

#include "gyrotc/algorithms/identify/identification.hpp"

// The workflow's "what to measure next": when two effects of the library
// predict nearly the same output over a record, the experiment whose record
// would tell them apart, from what each effect is (issue 74).
namespace gyrotc::identify {

// What a record covered, as far as it bears on telling two effects apart.
struct RecordCoverage {
  double low_c = 0.0;  // the casing's (or the table's) temperature range
  double high_c = 0.0;
  // The casing's ramps, |dT/dt| where it moves: 10th and 90th percentiles
  // (0: no ramps, a static table).
  double ramp_slow_c_per_min = 0.0;
  double ramp_fast_c_per_min = 0.0;
  double duration_s = 0.0;  // 0: a static table
};

// The experiment that would tell effect a from effect b (either order), in
// words with the record's own figures; empty where the library knows none.
std::string separating_experiment(const std::string& a, const std::string& b, const RecordCoverage& record);

// One alternative in words, for the report: "thermal_lag or rate_sensitivity
// (fitted contributions correlate 0.993 over the record): the record cannot
// tell them apart; what would: ...". An alternative the record told apart
// is named without the experiment.
std::string alternative_line(const Alternative& alternative);

}  // namespace gyrotc::identify
