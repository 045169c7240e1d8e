// Whether a time series can calibrate (record_screen.hpp): each check on a
// record made to fail it, and only it.
#include <cmath>
#include <vector>

#include "gyrotc/algorithms/fit/record_screen.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::fit;

namespace {

struct Series {
  std::vector<double> time_s;
  std::vector<double> sensor_c;
};

// `rate_c_per_min` from -20 C for `span_c`, sampled every `period_s`.
Series ramp(double rate_c_per_min, double span_c, double period_s) {
  Series s;
  const double duration_s = 60.0 * span_c / rate_c_per_min;
  for (double t = 0.0; t < duration_s; t += period_s) {
    s.time_s.push_back(t);
    s.sensor_c.push_back(-20.0 + rate_c_per_min * t / 60.0);
  }
  return s;
}

std::vector<ScreenCheck> checks(const Series& s, const ScreenLimits& limits = {}) {
  std::vector<ScreenCheck> out;
  for (const ScreenFinding& f : screen_calibration_record({s.time_s, s.sensor_c, std::nullopt, std::nullopt}, limits)) {
    out.push_back(f.check);
  }
  return out;
}

}  // namespace

TEST_CASE("a slow wide sweep passes every check") {
  CHECK(checks(ramp(0.2, 60.0, 1.0)).empty());
}

TEST_CASE("the rate of change is per minute whatever the record's period: 0.1 s and 20 s rows judge alike") {
  CHECK(checks(ramp(0.4, 60.0, 0.1)).empty());
  CHECK(checks(ramp(0.4, 60.0, 20.0)).empty());
  CHECK(checks(ramp(0.6, 60.0, 0.1)) == std::vector{ScreenCheck::unsettled});
  CHECK(checks(ramp(0.6, 60.0, 20.0)) == std::vector{ScreenCheck::unsettled});
}

TEST_CASE("a sweep narrower than the minimum span is refused for its span alone") {
  CHECK(checks(ramp(0.2, 15.0, 1.0)) == std::vector{ScreenCheck::span});
  ScreenLimits more_bins;
  more_bins.min_bins = 70;  // a model asking for more points than 60 bins of 1 C
  CHECK(checks(ramp(0.2, 60.0, 1.0), more_bins) == std::vector{ScreenCheck::span});
}

TEST_CASE("a hold is the casing at one setpoint, TEC on, for most of the record, without those columns it is not judged") {
  Series s = ramp(0.2, 60.0, 1.0);
  // Every sample "held" at its own setpoint when the columns are given...
  const std::vector<double> at_setpoint = s.sensor_c;
  RecordSamples held{s.time_s, s.sensor_c, std::span<const double>(at_setpoint), std::vector<bool>(s.time_s.size(), true)};
  // ...but each at a different setpoint: no single one holds half the record.
  CHECK(screen_calibration_record(held, {}).empty());
  // One setpoint the casing sits at for most of the record is a hold.
  Series hold = s;
  for (int i = 0; i < 20000; ++i) {
    hold.time_s.push_back(hold.time_s.back() + 1.0);
    hold.sensor_c.push_back(40.0);
  }
  const std::vector<double> sp40(hold.time_s.size(), 40.0);
  RecordSamples closed{hold.time_s, hold.sensor_c, std::span<const double>(sp40), std::vector<bool>(hold.time_s.size(), true)};
  const auto findings = screen_calibration_record(closed, {});
  REQUIRE_FALSE(findings.empty());
  CHECK(findings.front().check == ScreenCheck::held);
  CHECK(checks(hold) == std::vector{ScreenCheck::uneven});  // the same record, no columns: only its bins
}

namespace {

// Half a minute at +40 C, down to -20 C and back up at one rate, half a
// minute more at +40 C (the self-calibration's rests): every bin crossed
// once each way.
Series there_and_back(double rate_c_per_min, double period_s) {
  const Series down = ramp(rate_c_per_min, 60.0, period_s);
  Series s;
  auto add = [&s, period_s](double c) {
    s.time_s.push_back(s.time_s.empty() ? 0.0 : s.time_s.back() + period_s);
    s.sensor_c.push_back(c);
  };
  for (double t = 0.0; t < 30.0; t += period_s) add(40.0);
  for (double c : down.sensor_c) add(20.0 - c);  // -20 + x -> 40 - x
  for (double c : down.sensor_c) add(c);
  for (double t = 0.0; t < 30.0; t += period_s) add(40.0);
  return s;
}

}  // namespace

TEST_CASE("a bin crossed once down and once up at one rate is settled: the die's lag cancels in its mean") {
  CHECK(checks(ramp(0.8, 60.0, 1.0)) == std::vector{ScreenCheck::unsettled});  // one way: the lag stays
  CHECK(checks(there_and_back(0.8, 1.0)).empty());
}

TEST_CASE("a bin crossed both ways faster than the crossing limit is refused however balanced") {
  CHECK(checks(there_and_back(1.9, 1.0)).empty());
  CHECK(checks(there_and_back(2.5, 1.0)) == std::vector{ScreenCheck::unsettled});
}
