#include <cmath>
#include <numbers>
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

SeriesOptions fast_series() {
  SeriesOptions o;
  o.max_bins = 600;
  return o;
}

}  // namespace

TEST_CASE("a record with no hidden effect is answered none") {
  const auto id = identify_series(generate_record(spec(ChamberProfile::up_down_ramps, 5001)),
                                  SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "none");
  CHECK(id.added.empty());
}

TEST_CASE("a hidden thermal lag on up-and-down ramps is named, with its time constant") {
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5002);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
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
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "warm_up");
}

TEST_CASE("two hidden effects are both named, in the order found") {
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5004);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  s.effects.warm_up = WarmUpEffect{2.0, 600.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK((id.verdict == "thermal_lag+warm_up" || id.verdict == "warm_up+thermal_lag"));
}

TEST_CASE("a monotone staircase does not claim a lag that a flexible bias curve absorbs") {
  RecordSpec s = spec(ChamberProfile::staircase, 5005);
  s.effects.thermal_lag = ThermalLagEffect{150.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict.find("thermal_lag") == std::string::npos);
  CHECK_FALSE(id.note.empty());
}

// The casing's thermal resistance of these records: not the generator's
// default, so an estimator that fell back on a constant of its own would miss.
constexpr double kRecordRthKPerW = 3.2;

TEST_CASE("missing TEC Joule heating in the casing balance is named on sensor_c, with r_ohm from the given r_th") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5006);
  s.tec_step_a = 1.5;
  s.casing_r_th_k_per_w = kRecordRthKPerW;
  s.effects.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{1.2};
  SeriesOptions o = fast_series();
  o.casing_r_th_k_per_w = kRecordRthKPerW;  // the user's --r-th
  const auto id = identify_series(generate_record(s), SeriesTarget::sensor_c, o);
  CHECK(id.verdict == "tec_joule_heating");
  REQUIRE(id.added.size() == 1);
  REQUIRE(id.added[0].params.size() == 2);
  CHECK(id.added[0].params[0].name == "r_ohm");
  CHECK(id.added[0].params[0].value == Approx(1.2).epsilon(0.1));
}

TEST_CASE("without the casing's thermal resistance the Joule term is the rise per A^2 only, never an r_ohm") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5006);
  s.tec_step_a = 1.5;
  s.casing_r_th_k_per_w = kRecordRthKPerW;
  s.effects.tec_joule_heating = gyrotc::model::TecJouleHeatingEffect{1.2};
  const auto id = identify_series(generate_record(s), SeriesTarget::sensor_c, fast_series());
  CHECK(id.verdict == "tec_joule_heating");
  REQUIRE(id.added.size() == 1);
  REQUIRE(id.added[0].params.size() == 1);
  CHECK(id.added[0].params[0].name == "rise_k_per_a2");
  CHECK(id.added[0].params[0].value == Approx(kRecordRthKPerW * 1.2 / 2.0).epsilon(0.1));
}

TEST_CASE("sensor_c without Joule heating is answered none") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5007);
  s.tec_step_a = 1.5;
  const auto id = identify_series(generate_record(s), SeriesTarget::sensor_c, fast_series());
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

TEST_CASE("a lag on a narrow temperature range is answered as the lag or as an ambiguity naming it") {
  // 22..34 C: the bias slope is nearly constant, so a lag and a rate
  // sensitivity (and, on this one-node casing, an ambient sensitivity) act
  // alike; naming one of the others alone would be wrong.
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5008);
  s.low_c = 22.0;
  s.high_c = 34.0;
  s.noise_mv = 1.0;
  s.effects.thermal_lag = ThermalLagEffect{30.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  const bool named = id.verdict == "thermal_lag" ||
                     (id.verdict.rfind("ambiguous:", 0) == 0 && id.verdict.find("thermal_lag") != std::string::npos);
  CHECK(named);
}

TEST_CASE("an ambient sensitivity is named when TEC steps decouple the casing from the ambient") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5009);
  s.tec_step_a = 1.5;
  s.effects.ambient_sensitivity = gyrotc::model::AmbientSensitivityEffect{0.1, 25.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "ambient_sensitivity");
  REQUIRE_FALSE(id.added.empty());
  CHECK(id.added[0].params[0].value == Approx(0.1).epsilon(0.2));
}

TEST_CASE("on a one-node casing an ambient sensitivity is ambiguous with a rate sensitivity, and the note says why") {
  // ambient - T = tau dT/dt exactly: the two effects give the same record.
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5010);
  s.effects.ambient_sensitivity = gyrotc::model::AmbientSensitivityEffect{0.1, 25.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "ambiguous:rate_sensitivity+ambient_sensitivity");
  CHECK(id.note.find("cannot be told apart") != std::string::npos);
}

TEST_CASE("a periodic disturbance outside the library is reported as unexplained structure, not as an effect") {
  RecordSpec s = spec(ChamberProfile::up_down_ramps, 5011);
  SeriesRecord r = generate_record(s);
  for (std::size_t i = 0; i < r.gyro_mv.size(); ++i) r.gyro_mv[i] += 0.5 * std::sin(2.0 * std::numbers::pi * r.time_s[i] / 5400.0);
  const auto id = identify_series(r, SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "unexplained");
  CHECK(id.statement.find("none of the library's effects explains the residual") == 0);
}

TEST_CASE("a verdict is worded as what the record is consistent with") {
  RecordSpec s = spec(ChamberProfile::random_steps, 5012);
  s.effects.warm_up = WarmUpEffect{2.0, 600.0};
  const auto id = identify_series(generate_record(s), SeriesTarget::gyro_mv, fast_series());
  CHECK(id.verdict == "warm_up");
  CHECK(id.statement == "consistent with warm_up");
}
