// The experiment that would tell two of the library's effects apart (issue
// 74's "what to measure next").
#include "gyrotc/algorithms/identify/separating_experiment.hpp"

#include <string>

#include "gyrotc_catch.hpp"

using namespace gyrotc::identify;

namespace {

RecordCoverage narrow_ramps() {
  RecordCoverage c;
  c.low_c = 30.6;
  c.high_c = 41.3;
  c.ramp_slow_c_per_min = 0.21;
  c.ramp_fast_c_per_min = 0.48;
  c.duration_s = 6.5 * 3600.0;
  return c;
}

bool mentions(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("the experiment for two effects does not depend on which was named first") {
  const RecordCoverage c = narrow_ramps();
  for (const auto& [a, b] : {std::pair{"thermal_lag", "rate_sensitivity"}, {"ramp_hysteresis", "thermal_lag"},
                             {"ambient_sensitivity", "rate_sensitivity"}, {"warm_up", "linear_drift"},
                             {"gas_desorption", "parallel_loss"}}) {
    INFO(a << " / " << b);
    CHECK_FALSE(separating_experiment(a, b, c).empty());
    CHECK(separating_experiment(a, b, c) == separating_experiment(b, a, c));
  }
}

TEST_CASE("a lag and a rate sensitivity are told apart over a wider range than the record's") {
  const std::string e = separating_experiment("thermal_lag", "rate_sensitivity", narrow_ramps());
  CHECK(mentions(e, "wider range (this one spans 30.6..41.3 C)"));
}

TEST_CASE("a hysteresis and a rate sensitivity are told apart by two ramp rates, beside the record's own") {
  const std::string e = separating_experiment("rate_sensitivity", "ramp_hysteresis", narrow_ramps());
  CHECK(mentions(e, "two rates at least 3x apart (this record's: 0.21..0.48 C/min)"));
  CHECK(mentions(e, "rate_sensitivity grows in proportion"));
}

TEST_CASE("an ambient sensitivity is told from an effect of the casing by moving the casing with the room held") {
  CHECK(mentions(separating_experiment("ambient_sensitivity", "thermal_lag", narrow_ramps()), "TEC steps with the chamber held"));
}

TEST_CASE("a warm-up and a drift are told apart by a longer record, the record's length given") {
  CHECK(mentions(separating_experiment("linear_drift", "warm_up", narrow_ramps()), "(this one: 6.5 h)"));
}

TEST_CASE("two effects the library knows no experiment for get none") {
  CHECK(separating_experiment("tec_joule_heating", "quadratic_tc", narrow_ramps()).empty());
}

TEST_CASE("a tie is written with its correlation and the experiment, an alternative told apart without it") {
  Alternative a{"thermal_lag", "rate_sensitivity", 0.9936, false, "a wider range"};
  CHECK(alternative_line(a) ==
        "thermal_lag or rate_sensitivity (fitted contributions correlate 0.994 over the record): the record cannot "
        "tell them apart; what would: a wider range");
  a.told_apart = true;
  CHECK(alternative_line(a) ==
        "thermal_lag, not rate_sensitivity (fitted contributions correlate 0.994 over the record): the record told "
        "them apart");
}
