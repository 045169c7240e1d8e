#include <string>

#include "gyrotc/algorithms/identify/record_generator.hpp"
#include "gyrotc/algorithms/identify/series_identify.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::identify;
using gyrotc::model::ThermalLagEffect;
using gyrotc::model::WarmUpEffect;

namespace {

// Four hours at 1 Hz: long enough for every effect, short enough for a
// Debug+ASan run. Seeds here are not those the thresholds were fixed on.
RecordSpec spec(ChamberProfile profile, std::uint64_t seed) {
  RecordSpec s;
  s.profile = profile;
  s.duration_s = 4.0 * 3600.0;
  s.seed = seed;
  return s;
}

SeriesOptions fast() {
  SeriesOptions o;
  o.max_bins = 600;
  return o;
}

}  // namespace

TEST_CASE("a record with no hidden effect is answered none") {
  const auto id = identify_series(generate_record(spec(ChamberProfile::up_down_ramps, 5001)),
                                  SeriesTarget::gyro_mv, fast());
  CHECK(id.verdict == "none");
  CHECK(id.added.empty());
}

TEST_CASE("a hidden thermal lag on up-and-down ramps is named, with its time constant") {
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5002);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast());
  CHECK(id.verdict == "thermal_lag");
  REQUIRE(id.added.size() == 1);
  CHECK(id.added[0].params[0].value == Approx(150.0).epsilon(0.1));
  CHECK(id.shrink > 3.0);
  CHECK(id.whiteness_p_after > id.whiteness_p_before);
}

TEST_CASE("a warm-up under AR(1) noise on random steps is named warm_up") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5003);
  s.noise = NoiseKind::ar1;
  s.effects.warm_up = WarmUpEffect{2.0, 600.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast());
  CHECK(id.verdict == "warm_up");
}

TEST_CASE("two hidden effects are both named, in the order found") {
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5004);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  s.effects.warm_up = WarmUpEffect{2.0, 600.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast());
  CHECK((id.verdict == "thermal_lag+warm_up" || id.verdict == "warm_up+thermal_lag"));
}

TEST_CASE("a monotone staircase does not claim a lag that a flexible bias curve absorbs") {
  RecordSpec s = spec(ChamberProfile::staircase, 5005);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast());
  CHECK(id.verdict.find("thermal_lag") == std::string::npos);
  CHECK_FALSE(id.note.empty());
}

TEST_CASE("missing TEC Joule heating in the casing balance is named on sensor_c, with r_ohm") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5006);
  s.tec_step_a = 1.5;
  s.effects.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{1.2};
  const auto id = identify_series(generate_record(s), SeriesTarget::sensor_c, fast());
  CHECK(id.verdict == "tec_joule_heating");
  REQUIRE(id.added.size() == 1);
  CHECK(id.added[0].params[0].value == Approx(1.2).epsilon(0.1));
}

TEST_CASE("sensor_c without Joule heating is answered none") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5007);
  s.tec_step_a = 1.5;
  const auto id = identify_series(generate_record(s), SeriesTarget::sensor_c, fast());
  CHECK(id.verdict == "none");
}

TEST_CASE("a record too short or without tec_a for sensor_c is refused") {
  SeriesRecord r;
  r.time_s = {0, 1, 2};
  r.ambient_c = r.sensor_c = r.gyro_mv = {20, 20, 20};
  CHECK_THROWS_AS(identify_series(r, SeriesTarget::gyro_mv), std::invalid_argument);
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 1);
  s.duration_s = 1000;
  SeriesRecord no_tec = generate_record(s);
  no_tec.tec_a.clear();
  CHECK_THROWS_AS(identify_series(no_tec, SeriesTarget::sensor_c), std::invalid_argument);
}
