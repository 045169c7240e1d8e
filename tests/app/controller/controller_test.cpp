#include <cmath>
#include <memory>
#include <string>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::app;
using gyrotc::fit::BiasModel;
using gyrotc::fit::Compensator;
using gyrotc::hal::AdcSample;
using gyrotc::hal::TempFault;
using gyrotc::hal::TemperatureReading;

namespace {

TemperatureReading good(double temp_c, double t_s) { return {temp_c, t_s, true, TempFault::none}; }
TemperatureReading bad(double t_s, TempFault fault) { return {0.0, t_s, false, fault}; }

// An ADC sample at the zero-rate output (the runners deliver hundreds a second).
AdcSample sample() {
  AdcSample s;
  s.gyro_mv = 80.0;
  return s;
}

// A controller fed a reading and an ADC sample every second and ticked every
// 2 s, as the runners do. The reading alternates between two values one
// DS18B20 step apart unless a fixed value is given.
struct Harness {
  Compensator compensator{BiasModel::paper_reference()};
  ControllerConfig config;
  Controller controller;
  double now_s = 0.0;
  bool adc = true;  // false: no ADC sample (a dead converter)

  explicit Harness(ControllerConfig c = {}) : config(c), controller(c, compensator) {}

  TecCommand run_for(double seconds, double temp_c, bool deliver = true, bool jitter = true) {
    TecCommand last = controller.last_command();
    const double end = now_s + seconds;
    while (now_s < end - 1e-9) {
      now_s += 1.0;
      if (adc) (void)controller.on_sample(sample(), now_s);
      const double value = jitter && (static_cast<long>(now_s) % 2 == 0) ? temp_c + 0.0625 : temp_c;
      if (deliver) controller.on_temperature(good(value, now_s - 0.75), now_s);
      if (static_cast<long>(now_s) % 2 == 0) last = controller.on_pid_tick(now_s);
    }
    return last;
  }
};

}  // namespace

TEST_CASE("a casing colder than the setpoint drives positive (heating) TEC current") {
  Harness h;
  const TecCommand cmd = h.run_for(10.0, 40.0);
  CHECK(cmd.enable);
  CHECK(cmd.current_a > 0.0);
  CHECK((cmd.flags & kFlagTecOff) == 0);
}

TEST_CASE("every sample is compensated at the last casing temperature") {
  Harness h;
  h.run_for(4.0, 30.0, true, false);
  const BiasModel model = BiasModel::paper_reference();
  AdcSample s;
  s.gyro_mv = model.bias_mv(30.0) + 8.774 * 2.0;
  const SampleResult r = h.controller.on_sample(s, h.now_s);
  CHECK(r.valid);
  CHECK(r.rate_dps == Approx(2.0).margin(1e-9));
  CHECK(r.rate_out_v == Approx(2.5 + 2.0 * 0.01));
}

TEST_CASE("a calibration of the die is evaluated at the die's temperature: on a ramp, lag x rate behind the reading") {
  // bias = 100 - 2 mV/C x T; the casing read every second rising 0.05 C/s for
  // 20 lags of 30 s: the die settles 1.5 C behind the reading.
  gyrotc::fit::Polynomial line;
  line.coefficients_mv = {100.0, -2.0};
  line.t_min_c = -40.0;
  line.t_max_c = 80.0;
  const Compensator die(BiasModel::polynomial(line), 8.774, 30.0);
  ControllerConfig config;
  config.pid_enabled = false;
  Controller controller(config, die);
  double casing_c = 20.0;
  for (int i = 0; i <= 600; ++i) {
    casing_c = 20.0 + 0.05 * i;
    controller.on_temperature(good(casing_c, i), i + 0.75);
  }
  CHECK(controller.compensation_c() == Approx(casing_c - 1.5).margin(1e-6));
  AdcSample s;
  s.gyro_mv = 100.0 - 2.0 * (casing_c - 1.5);  // the die's zero-rate output: no rate
  const SampleResult r = controller.on_sample(s, 601.0);
  CHECK(r.valid);
  CHECK(r.rate_dps == Approx(0.0).margin(1e-6));
  // The same calibration without the lag takes 3 mV less bias: 0.34 deg/s.
  const Compensator sensor(BiasModel::polynomial(line), 8.774);
  controller.set_compensator(sensor);
  controller.on_temperature(good(casing_c, 601.0), 601.75);
  CHECK(controller.on_sample(s, 602.0).rate_dps == Approx(3.0 / 8.774).margin(1e-6));
}

TEST_CASE("a calibration of the die flags a die outside its range, not a reading") {
  gyrotc::fit::Polynomial line;
  line.coefficients_mv = {100.0};
  line.t_min_c = 0.0;
  line.t_max_c = 40.0;
  const Compensator die(BiasModel::polynomial(line), 8.774, 300.0);
  ControllerConfig config;
  config.pid_enabled = false;
  Controller controller(config, die);
  controller.on_temperature(good(38.0, 0.0), 0.75);
  // The casing jumps to 45 C: outside the range, but the die is still near 38 C.
  controller.on_temperature(good(45.0, 1.0), 1.75);
  CHECK((controller.on_sample(sample(), 2.0).flags & kFlagModelClamped) == 0);
  for (int i = 2; i < 2000; ++i) controller.on_temperature(good(45.0, i), i + 0.75);
  CHECK((controller.on_sample(sample(), 2001.0).flags & kFlagModelClamped) != 0);
}

TEST_CASE("no reading for more than 3 PID periods turns the TEC off, flags it and recovers") {
  Harness h;
  h.run_for(10.0, 54.0);
  TecCommand cmd = h.run_for(8.0, 54.0, /*deliver=*/false);  // > 3 periods of 2 s
  CHECK_FALSE(cmd.enable);
  CHECK(cmd.current_a == 0.0);
  CHECK((cmd.flags & kFlagTempStale) != 0);
  CHECK((cmd.flags & kFlagTecOff) != 0);
  cmd = h.run_for(2.0, 54.0);  // two good readings: not yet (M = 3)
  CHECK_FALSE(cmd.enable);
  cmd = h.run_for(2.0, 54.0);
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagTempStale) == 0);
}

// One reading per PID period, just before the tick: the case where a
// glitch leaves a period with no valid reading at all.
struct PeriodHarness {
  Compensator compensator{BiasModel::paper_reference()};
  Controller controller{ControllerConfig{}, compensator};
  double now_s = 0.0;
  TecCommand period(const TemperatureReading& reading) {
    now_s += 2.0;
    (void)controller.on_sample(sample(), now_s);
    controller.on_temperature(reading, now_s);
    return controller.on_pid_tick(now_s);
  }
  TecCommand good_period(double temp_c) { return period(good(temp_c, now_s + 2.0 - 0.75)); }
};

TEST_CASE("a single invalid reading changes the TEC current by less than one PID step") {
  PeriodHarness h;
  // Settling below the setpoint: the integral moves the current every period.
  for (int i = 0; i < 5; ++i) h.good_period(54.8);
  const TecCommand before = h.good_period(54.8);
  const TecCommand reference = h.good_period(54.8);
  const double pid_step_a = std::fabs(reference.current_a - before.current_a);
  REQUIRE(pid_step_a > 1e-3);
  const TecCommand glitch = h.period(bad(h.now_s + 1.25, TempFault::crc));
  CHECK(glitch.enable);
  CHECK((glitch.flags & kFlagTempInvalid) != 0);
  CHECK((glitch.flags & kFlagTecOff) == 0);
  CHECK(std::fabs(glitch.current_a - reference.current_a) < pid_step_a);  // held
  // The next valid reading steps the PID from there, not from 0 A.
  const TecCommand after = h.good_period(54.8);
  CHECK(after.enable);
  CHECK(std::fabs(after.current_a - glitch.current_a) < 1.5 * pid_step_a);
}

TEST_CASE("invalid readings hold the TEC until the stale limit, then turn it off, flagged") {
  PeriodHarness h;
  for (int i = 0; i < 10; ++i) h.good_period(54.0);
  const double held_a = h.controller.last_command().current_a;
  // stale_periods (3 x 2 s) from the last good reading's measurement, 0.75 s
  // before its period: the 2nd invalid period (4.75 s on) is still within,
  // the 3rd (6.75 s) is not.
  for (int i = 0; i < 2; ++i) {
    const TecCommand cmd = h.period(bad(h.now_s + 1.25, i == 0 ? TempFault::power_on_value : TempFault::crc));
    CHECK(cmd.enable);
    CHECK(cmd.current_a == held_a);
  }
  const TecCommand off = h.period(bad(h.now_s + 1.25, TempFault::crc));
  CHECK_FALSE(off.enable);
  CHECK(off.current_a == 0.0);
  CHECK((off.flags & (kFlagTempStale | kFlagTempInvalid | kFlagTecOff)) ==
        (kFlagTempStale | kFlagTempInvalid | kFlagTecOff));
}

TEST_CASE("after a sensor fault at an unchanged casing the PID restarts where it stopped, once M good readings came") {
  PeriodHarness h;
  for (int i = 0; i < 40; ++i) h.good_period(54.9);
  const double held_a = h.controller.last_command().current_a;
  REQUIRE(std::fabs(held_a) > 0.05);
  for (int i = 0; i < 5; ++i) h.period(bad(h.now_s + 1.25, TempFault::crc));
  REQUIRE_FALSE(h.controller.last_command().enable);
  TecCommand cmd = h.good_period(54.9);
  cmd = h.good_period(54.9);
  CHECK_FALSE(cmd.enable);  // two good readings: not yet (M = 3)
  cmd = h.good_period(54.9);
  CHECK(cmd.enable);
  CHECK((cmd.flags & (kFlagTempInvalid | kFlagTempStale)) == 0);
  // From the held current plus this period's integral step (e = -0.1 C): not
  // from 0 A, and without the proportional part counted a second time.
  const double ki = ControllerConfig{}.pid.ki();
  CHECK(cmd.current_a == Approx(held_a + ki * 0.1).margin(1e-9));
}

TEST_CASE("after a sensor fault during which the casing cooled the PID restarts with its integral and heats the fall back") {
  PeriodHarness h;
  for (int i = 0; i < 10; ++i) h.good_period(54.9);
  const double held_a = h.controller.last_command().current_a;
  for (int i = 0; i < 5; ++i) h.period(bad(h.now_s + 1.25, TempFault::crc));
  REQUIRE_FALSE(h.controller.last_command().enable);
  // The TEC was off: the casing is 2 C colder when the readings come back.
  h.good_period(52.9);
  h.good_period(52.9);
  const TecCommand cmd = h.good_period(52.9);
  REQUIRE(cmd.enable);
  // The held current plus Kp for each degree of the fall (PD outside the
  // band). Restarted from the held output instead, the PD would take 52.9 C
  // for its setpoint and hold the casing there.
  const double kp = ControllerConfig{}.pid.kp;
  CHECK(cmd.current_a == Approx(held_a + kp * 2.0).margin(1e-9));
}

TEST_CASE("with invalid readings between valid ones the PID keeps regulating on the valid ones") {
  Harness h;
  h.run_for(10.0, 54.0);
  for (int i = 0; i < 20; ++i) {
    h.now_s += 1.0;
    h.controller.on_temperature(bad(h.now_s, TempFault::crc), h.now_s);  // every other reading: a flaky bus
    h.now_s += 1.0;
    (void)h.controller.on_sample(sample(), h.now_s);
    h.controller.on_temperature(good(50.0, h.now_s - 0.75), h.now_s);
    (void)h.controller.on_pid_tick(h.now_s);
  }
  const TecCommand cmd = h.controller.last_command();
  CHECK(cmd.enable);
  CHECK(cmd.current_a > 0.5);  // heating towards 55 C from a casing at 50 C
  CHECK((cmd.flags & kFlagTempInvalid) != 0);  // never M good readings in a row
}

TEST_CASE("85 C power-on and out-of-range readings are invalid, never the controller's input") {
  Harness h;
  h.run_for(10.0, 54.0);
  h.controller.on_temperature(bad(h.now_s, TempFault::power_on_value), h.now_s);
  h.controller.on_temperature(good(200.0, h.now_s), h.now_s);
  CHECK((h.controller.flags() & kFlagTempInvalid) != 0);
  CHECK(h.controller.last_casing_c() != 200.0);
  const TecCommand cmd = h.run_for(6.0, 54.0);
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagTempInvalid) == 0);
}

TEST_CASE("a reading stuck while the TEC drives hard turns the TEC off until the value moves") {
  Harness h;
  // Stuck at 50 C: PD drives > 0.5 A all along, the reading never changes.
  TecCommand cmd = h.run_for(290.0, 50.0, true, false);
  CHECK(cmd.enable);
  cmd = h.run_for(20.0, 50.0, true, false);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagTempStuck) != 0);
  cmd = h.run_for(10.0, 50.0, true, false);  // still the same value: stays off
  CHECK_FALSE(cmd.enable);
  cmd = h.run_for(4.0, 49.0);  // the sensor moves again: M good readings
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagTempStuck) == 0);
}

TEST_CASE("a steady reading at the setpoint with little drive is not taken for a stuck sensor") {
  Harness h;
  const TecCommand cmd = h.run_for(1200.0, 55.0, true, false);
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagTempStuck) == 0);
}

TEST_CASE("casing over-temperature latches the TEC off even after good readings") {
  Harness h;
  h.run_for(10.0, 54.0);
  h.controller.on_temperature(good(81.0, h.now_s), h.now_s);
  TecCommand cmd = h.controller.on_pid_tick(h.now_s);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagOverTempLatched) != 0);
  cmd = h.run_for(60.0, 54.0);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagOverTempLatched) != 0);
}

TEST_CASE("the OPA548 thermal flag turns the TEC off, reported, for the cool-down time") {
  Harness h;
  h.run_for(10.0, 54.0);
  h.controller.on_opa548_thermal(true, h.now_s);
  TecCommand cmd = h.run_for(2.0, 54.0);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagOpa548Thermal) != 0);
  // Disabled, the part reads "no fault": the TEC stays off until the cool-down is over.
  h.controller.on_opa548_thermal(false, h.now_s);
  cmd = h.run_for(2.0, 54.0);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagOpa548Thermal) != 0);
  h.run_for(h.config.limits.opa548_cooldown_s, 54.0);
  h.controller.on_opa548_thermal(false, h.now_s);
  cmd = h.run_for(2.0, 54.0);
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagOpa548Thermal) == 0);
}

TEST_CASE("an ADC timeout flags the rate output invalid until the next good sample") {
  Harness h;
  h.run_for(4.0, 30.0);
  h.controller.on_adc_timeout(h.now_s);
  CHECK((h.controller.flags() & kFlagAdcInvalid) != 0);
  AdcSample clipped;
  clipped.clipped = true;
  SampleResult r = h.controller.on_sample(clipped, h.now_s);
  CHECK_FALSE(r.valid);
  CHECK(r.rate_out_v == Approx(2.5));  // mid-scale
  CHECK((r.flags & kFlagAdcInvalid) != 0);
  AdcSample fine;
  fine.gyro_mv = 80.0;
  r = h.controller.on_sample(fine, h.now_s);
  CHECK(r.valid);
  CHECK((r.flags & kFlagAdcInvalid) == 0);
}

TEST_CASE("a reading is stale stale_periods after it was measured, not after it was handed over") {
  Harness h;
  h.run_for(10.0, 50.0);  // now 10 s, the last reading measured at 9.25 s
  // The last reading before the sensor goes: measured at 9.9 s, delivered at
  // 10.8 s (a conversion), then nothing.
  h.controller.on_temperature(good(50.0, 9.9), 10.8);
  CHECK(h.controller.on_pid_tick(12.0).enable);
  CHECK(h.controller.on_pid_tick(14.0).enable);
  // 6 s (stale_periods x period) after 9.9 s: off at the tick at 16 s, not 18 s.
  const TecCommand cmd = h.controller.on_pid_tick(16.0);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagTempStale) != 0);
}

TEST_CASE("no ADC sample for adc_stall_s is flagged adc_stalled, and the TEC loop goes on driving") {
  Harness h;
  h.run_for(20.0, 50.0);
  REQUIRE(h.controller.last_command().enable);
  h.adc = false;  // DRDY stopped: the runners only see timeouts now
  TecCommand cmd = h.run_for(h.config.limits.adc_stall_s - 2.0, 50.0);
  CHECK((cmd.flags & kFlagAdcStalled) == 0);  // not yet: a few timeouts are no dead converter
  cmd = h.run_for(4.0, 50.0);
  CHECK((cmd.flags & kFlagAdcStalled) != 0);
  CHECK(cmd.enable);  // the temperature loop needs neither the ADC nor the rate DAC
  CHECK((cmd.flags & (kFlagTecOff | kFlagUncontrolled)) == 0);
  h.adc = true;
  cmd = h.run_for(2.0, 50.0);
  CHECK(cmd.enable);
  CHECK((cmd.flags & kFlagAdcStalled) == 0);
}

TEST_CASE("an ADC that never delivers is flagged adc_stall_s after the first tick, and the TEC drives all along") {
  Harness h;
  h.adc = false;
  TecCommand cmd = h.run_for(4.0, 40.0);
  CHECK(cmd.enable);
  cmd = h.run_for(h.config.limits.adc_stall_s, 40.0);
  CHECK(cmd.enable);
  CHECK(cmd.current_a > 0.0);
  CHECK((cmd.flags & kFlagAdcStalled) != 0);
}

TEST_CASE("every fault flag has a name for the journal, and a bit that is no flag has none") {
  for (const std::uint32_t f : {kFlagTempStale, kFlagTempInvalid, kFlagTempStuck, kFlagOverTempLatched,
                                kFlagOpa548Thermal, kFlagAdcInvalid, kFlagModelClamped, kFlagTecSaturated, kFlagTecOff,
                                kFlagAdcStalled, kFlagTecWriteFailed, kFlagRateDacFailed, kFlagUncontrolled,
                                kFlagAmbientStale, kFlagLoopRunaway}) {
    CHECK(std::string(flag_name(f)).size() > 3);
  }
  CHECK(std::string(flag_name(1u << 20)).empty());
  CHECK(std::string(flag_name(kFlagAdcStalled)) == "adc_stalled");
}

TEST_CASE("a flags word reads as the names of its flags, as the journal prints it") {
  CHECK(flag_names(0) == "none");
  CHECK(flag_names(kFlagTecOff | kFlagModelClamped) == "model_clamped+tec_off");
  CHECK(flag_names(448) == "model_clamped+tec_saturated+tec_off");
  CHECK(flag_names(kFlagTecOff | (1u << 20)) == "tec_off+bit 20");
}

TEST_CASE("the runners' sample tick drives the rate DAC and averages only valid samples into the row") {
  struct LastWrite final : gyrotc::hal::RateDac {
    double volts = -1.0;
   private:
    gyrotc::hal::Status do_write_v(double v) noexcept override {
      volts = v;
      return gyrotc::hal::Status::success();
    }
    gyrotc::hal::Status do_power_down() noexcept override { return gyrotc::hal::Status::success(); }
  } dac;
  Harness h;
  h.run_for(4.0, 30.0, true, false);
  const double bias_mv = BiasModel::paper_reference().bias_mv(30.0);
  RowAccumulator row;
  CHECK(std::isnan(row.mean_gyro_mv()));
  CHECK(std::isnan(row.mean_rate_dps()));

  AdcSample s;
  s.gyro_mv = bias_mv + 8.774 * 1.0;
  SampleResult r = run_sample_tick(h.controller, dac, s, h.now_s, row);
  CHECK(dac.volts == r.rate_out_v);
  s.gyro_mv = bias_mv + 8.774 * 3.0;
  (void)run_sample_tick(h.controller, dac, s, h.now_s, row);
  AdcSample clipped;
  clipped.gyro_mv = 5000.0;
  clipped.clipped = true;
  r = run_sample_tick(h.controller, dac, clipped, h.now_s, row);
  CHECK_FALSE(r.valid);

  CHECK(row.gyro_count == 3);
  CHECK(row.rate_count == 2);
  CHECK(row.mean_rate_dps() == Approx(2.0).margin(1e-9));  // the clipped sample left out
  CHECK(row.mean_gyro_mv() == Approx((2.0 * bias_mv + 8.774 * 4.0 + 5000.0) / 3.0));
  CHECK((row.flags & kFlagAdcInvalid) != 0);

  run_adc_timeout_tick(h.controller, dac, h.now_s, row);
  CHECK(dac.volts == Approx(2.5));  // mid-scale: zero rate
}

TEST_CASE("before the first casing reading the rate is invalid, and the model is not flagged clamped") {
  Harness h;
  const SampleResult before = h.controller.on_sample(sample(), 0.5);
  CHECK_FALSE(before.valid);
  CHECK((before.flags & kFlagModelClamped) == 0);
  // A reading outside the calibration's range (the seed's -40..80 C) is.
  h.controller.on_temperature(good(-45.0, 0.6), 0.9);
  const SampleResult outside = h.controller.on_sample(sample(), 1.0);
  CHECK((outside.flags & kFlagModelClamped) != 0);
}

TEST_CASE("the compensator can be swapped between samples") {
  Harness h;
  h.run_for(4.0, 30.0, true, false);
  gyrotc::fit::Polynomial flat;
  flat.coefficients_mv = {50.0};
  flat.t_min_c = -40.0;
  flat.t_max_c = 80.0;
  const Compensator replacement(BiasModel::polynomial(flat));
  h.controller.set_compensator(replacement);
  AdcSample s;
  s.gyro_mv = 50.0;
  CHECK(h.controller.on_sample(s, h.now_s).rate_dps == Approx(0.0).margin(1e-12));
}

TEST_CASE("a replaced compensator is reported in use until a sample has used the new one") {
  Harness h;
  const Compensator first(BiasModel::paper_reference());
  h.controller.set_compensator(first);
  AdcSample s;
  (void)h.controller.on_sample(s, h.now_s);
  CHECK(h.controller.compensator_in_use() == &first);
  const Compensator second(BiasModel::paper_reference());
  h.controller.set_compensator(second);
  CHECK(h.controller.compensator_in_use() == &first);  // no sample since: first may still be in use
  (void)h.controller.on_sample(s, h.now_s);
  CHECK(h.controller.compensator_in_use() == &second);
}

TEST_CASE("with the PID disabled the TEC is never enabled") {
  ControllerConfig c;
  c.pid_enabled = false;
  Harness h(c);
  const TecCommand cmd = h.run_for(20.0, 30.0);
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagTecOff) != 0);
}

TEST_CASE("a ramped setpoint starts at the casing temperature and moves at the set rate") {
  ControllerConfig c;
  c.setpoint_ramp_c_per_s = 0.05;
  Harness h(c);
  h.run_for(100.0, 20.0);  // stale at the first tick, then 3 readings to recover
  CHECK(h.controller.active_setpoint_c() > 20.0);
  CHECK(h.controller.active_setpoint_c() < 20.0 + 0.05 * 100.0 + 1e-9);
}

TEST_CASE("configurations that cannot work are rejected naming the field") {
  ControllerConfig c;
  c.setpoint_c = 90.0;  // above the over-temperature limit
  const Compensator comp(BiasModel::paper_reference());
  CHECK_THROWS_WITH(Controller(c, comp), Catch::Contains("setpoint_c"));
}

namespace {

// Integral-separated PI (KD 0) with a small Kp, so that an integral wound up
// beyond the limit would hold the output there for many periods.
ControllerConfig slow_pi() {
  ControllerConfig c;
  c.pid = gyrotc::control::PidParams::from_gains(0.2, 0.05, 0.0, 2.0);
  c.pid.xi_c = 1.0;
  c.pid.out_min = -1.0;
  c.pid.out_max = 1.0;
  return c;
}

// PID ticks (every 2 s, a reading every second) from the casing passing the
// setpoint until the current leaves max_a; -1 if it never does within 100 s.
int periods_to_leave(Harness& h, double casing_c, double max_a) {
  for (int k = 1; k <= 50; ++k) {
    const TecCommand cmd = h.run_for(2.0, casing_c, true, false);
    if (cmd.current_a < max_a - 1e-9) return k;
  }
  return -1;
}

}  // namespace

TEST_CASE("a TEC saturated by the feed-forward does not wind up: it leaves the limit within two periods") {
  ControllerConfig c = slow_pi();
  c.feed_forward_a_per_c = 0.01;  // at -45 C ambient: 1 A of feed-forward alone
  Harness h(c);
  h.controller.on_ambient_temperature(good(-45.0, 0.0), 0.0);
  // 0.4 C too cold inside the band for 20 min: the applied current sits at the
  // 1 A limit while the integral is asked for more every period.
  TecCommand cmd = h.run_for(1200.0, 54.6);  // readings 54.6 and 54.6625: not a stuck sensor
  CHECK(cmd.current_a == Approx(1.0));
  CHECK((cmd.flags & kFlagTecSaturated) != 0);
  // The casing passes the setpoint by one DS18B20 step: less heat is wanted.
  const int periods = periods_to_leave(h, 55.0625, 1.0);
  INFO("PID periods to leave the limit: " << periods);
  CHECK(periods >= 1);
  CHECK(periods <= 2);
}

TEST_CASE("a TEC held at the OPA548 rail limit does not wind up: it leaves the rail within two periods") {
  ControllerConfig c = slow_pi();
  // 12 ohm module, S 0.051 V/K, +/-15 V rails with 2.5 V of headroom.
  c.rail = RailLimit{true, 12.5 / 12.0, -12.5 / 12.0, 0.051 / 12.0};
  Harness h(c);
  h.controller.on_ambient_temperature(good(-30.0, 0.0), 0.0);
  const double rail_a = 12.5 / 12.0 - 0.051 / 12.0 * (54.6625 + 30.0);  // 0.68 A, below the 1 A limit
  TecCommand cmd = h.run_for(1200.0, 54.6);  // readings 54.6 and 54.6625: not a stuck sensor
  CHECK(cmd.current_a == Approx(rail_a).margin(1e-9));
  CHECK((cmd.flags & kFlagTecSaturated) != 0);
  const double rail_then_a = 12.5 / 12.0 - 0.051 / 12.0 * (55.0625 + 30.0);
  const int periods = periods_to_leave(h, 55.0625, rail_then_a);
  INFO("PID periods to leave the rail: " << periods);
  CHECK(periods >= 1);
  CHECK(periods <= 2);
}

namespace {

// A programme that asks for a fixed current and finishes after a while.
class FixedProgram final : public gyrotc::control::TecProgram {
 public:
  FixedProgram(double current_a, double until_s) : current_a_(current_a), until_s_(until_s) {}
  gyrotc::control::TecProgramInput last;
  int calls = 0;

 private:
  gyrotc::control::TecProgramOutput do_next(const gyrotc::control::TecProgramInput& in) noexcept override {
    last = in;
    ++calls;
    return {current_a_, in.time_s >= until_s_};
  }
  double current_a_;
  double until_s_;
};

}  // namespace

TEST_CASE("a TEC programme replaces the PID within the limits, and the TEC stays off once it finishes") {
  ControllerConfig c;
  c.pid.out_max = 0.8;
  Harness h(c);
  FixedProgram program(5.0, 20.0);
  h.controller.run_program(&program);
  TecCommand cmd = h.run_for(10.0, 30.0, true, false);
  CHECK(cmd.enable);
  CHECK(cmd.current_a == Approx(0.8));  // clamped to the limit
  CHECK((cmd.flags & kFlagTecSaturated) != 0);
  CHECK(program.last.max_a == Approx(0.8));
  CHECK(program.last.casing_c == Approx(30.0));
  CHECK(std::isnan(program.last.ambient_c));
  CHECK_FALSE(h.controller.program_finished());
  cmd = h.run_for(20.0, 30.0, true, false);
  CHECK(h.controller.program_finished());
  CHECK_FALSE(cmd.enable);
  CHECK(cmd.current_a == 0.0);
  const int calls = program.calls;
  cmd = h.run_for(10.0, 30.0, true, false);
  CHECK_FALSE(cmd.enable);
  CHECK(program.calls == calls);  // not asked again
}

TEST_CASE("a TEC programme gets the gyro's mean output over the samples since its last period, clipped ones left out") {
  Harness h;
  FixedProgram program(0.1, 1e9);
  h.controller.run_program(&program);
  h.run_for(2.0, 30.0, true, false);  // the first period: its samples are not the ones below
  const double t = h.now_s;
  for (double mv : {100.0, 104.0}) {
    AdcSample s;
    s.gyro_mv = mv;
    (void)h.controller.on_sample(s, t + 0.5);
  }
  AdcSample clipped;
  clipped.gyro_mv = 2500.0;
  clipped.clipped = true;
  (void)h.controller.on_sample(clipped, t + 0.6);
  h.controller.on_temperature(good(30.0, t + 0.7), t + 0.7);
  (void)h.controller.on_pid_tick(t + 2.0);
  CHECK(program.last.gyro_mv == Approx(102.0));
  CHECK(program.last.gyro_scale_mv_per_dps == Approx(8.774));
  // A period without samples: no output to judge.
  h.controller.on_temperature(good(30.0, t + 3.0), t + 3.0);
  (void)h.controller.on_pid_tick(t + 4.0);
  CHECK(std::isnan(program.last.gyro_mv));
}

TEST_CASE("a TEC programme is not asked while a fail-safe holds the TEC off") {
  Harness h;
  FixedProgram program(0.3, 1e9);
  h.controller.run_program(&program);
  h.run_for(10.0, 30.0, true, false);
  const int calls = program.calls;
  const TecCommand cmd = h.run_for(8.0, 30.0, /*deliver=*/false);  // stale readings
  CHECK_FALSE(cmd.enable);
  CHECK((cmd.flags & kFlagTempStale) != 0);
  CHECK(program.calls <= calls + 3);  // only until the reading went stale
}

TEST_CASE("a TEC programme gets 0 A in a period with only an invalid reading, where the PID would hold") {
  PeriodHarness h;
  FixedProgram program(0.3, 1e9);
  h.controller.run_program(&program);
  for (int i = 0; i < 5; ++i) REQUIRE(h.good_period(40.0).enable);
  const int calls = program.calls;
  const TecCommand glitch = h.period(bad(h.now_s + 1.25, TempFault::crc));
  CHECK_FALSE(glitch.enable);
  CHECK(glitch.current_a == 0.0);
  CHECK((glitch.flags & kFlagTempInvalid) != 0);
  CHECK(program.calls == calls);  // not asked while the reading is faulty
}

TEST_CASE("a reload's new gains take over at the next PID period without a step in the current") {
  Harness h;
  h.run_for(20.0, 54.8, true, false);  // a steady -0.2 C hold, the integral still within the limits
  const double before = h.controller.last_command().current_a;
  ControllerConfig gains = h.config;
  gains.pid = gyrotc::control::PidParams::from_gains(0.96, 0.64, 20.0, 2.0);
  gains.pid.out_min = h.config.pid.out_min;
  gains.pid.out_max = h.config.pid.out_max;
  ControllerReload next(gains);
  h.controller.request_reload(next);
  CHECK(h.controller.reload_applied() == nullptr);  // not before the loop's next period
  const TecCommand after = h.run_for(2.0, 54.8, true, false);
  CHECK(h.controller.reload_applied() == &next);
  CHECK(h.controller.config().pid.kp == 0.96);
  // One period's integral step of the new KI (0.64 x 0.2 C), not Kp e on top.
  CHECK(after.current_a - before == Approx(0.128));
}

TEST_CASE("a reloaded setpoint ramps from the one in use at the configured rate") {
  ControllerConfig c;
  c.setpoint_ramp_c_per_s = 0.01;
  Harness h(c);
  h.run_for(400.0, 55.0);
  REQUIRE(h.controller.active_setpoint_c() == Approx(55.0));
  ControllerConfig lower = c;
  lower.setpoint_c = 50.0;
  ControllerReload next(lower);
  h.controller.request_reload(next);
  h.run_for(100.0, 55.0);
  CHECK(h.controller.config().setpoint_c == 50.0);
  CHECK(h.controller.active_setpoint_c() == Approx(54.0).margin(0.03));
}

TEST_CASE("a reload that turns the PID off turns the TEC off at the next period") {
  Harness h;
  REQUIRE(h.run_for(20.0, 40.0).enable);
  ControllerConfig off = h.config;
  off.pid_enabled = false;
  ControllerReload next(off);
  h.controller.request_reload(next);
  const TecCommand cmd = h.run_for(2.0, 40.0);
  CHECK_FALSE(cmd.enable);
  CHECK(cmd.current_a == 0.0);
}

namespace {

// The current with the casing held at the setpoint (no PID action: the
// error is 0) and the ambient read every 10 s: 15 C for 100 s, then -25 C
// for `after_s`. ff 0.005 A/C: 0.2 A at 15 C, 0.4 A at -25 C.
double current_after_ambient_step(double lag_s, double after_s) {
  ControllerConfig c;
  c.feed_forward_a_per_c = 0.005;
  c.feed_forward_lag_s = lag_s;
  Harness h(c);
  TecCommand cmd;
  for (double t = 0.0; t < 100.0 + after_s - 1e-9; t += 10.0) {
    const double ambient_c = t < 100.0 ? 15.0 : -25.0;
    h.controller.on_ambient_temperature(good(ambient_c, h.now_s), h.now_s);
    cmd = h.run_for(10.0, 55.0, true, false);
  }
  return cmd.current_a;
}

}  // namespace

TEST_CASE("without a feed-forward lag the feed-forward follows an ambient step at once") {
  CHECK(current_after_ambient_step(0.0, 0.0) == Approx(0.2).margin(1e-9));
  CHECK(current_after_ambient_step(0.0, 10.0) == Approx(0.4).margin(1e-9));
}

TEST_CASE("with a feed-forward lag the feed-forward follows an ambient step as the housing does") {
  // 200 s of lag: 1 - exp(-t / 200) of the step after t seconds.
  CHECK(current_after_ambient_step(200.0, 10.0) == Approx(0.2 + 0.2 * (1.0 - std::exp(-10.0 / 200.0))).margin(1e-9));
  CHECK(current_after_ambient_step(200.0, 200.0) == Approx(0.2 + 0.2 * (1.0 - std::exp(-1.0))).margin(1e-9));
  CHECK(current_after_ambient_step(200.0, 2000.0) == Approx(0.4).margin(1e-4));
}

TEST_CASE("a negative feed-forward lag is rejected naming the field") {
  ControllerConfig c;
  c.feed_forward_lag_s = -1.0;
  const Compensator comp(BiasModel::paper_reference());
  CHECK_THROWS_WITH(Controller(c, comp), Catch::Contains("feed_forward_lag_s"));
}

TEST_CASE("the PID has no model estimate, the model-based loop reports its estimates once it has run") {
  Harness pid;
  pid.run_for(10.0, 50.0);
  CHECK(std::isnan(pid.controller.loop_estimate().held_c));

  ControllerConfig config;
  gyrotc::control::ObserverLoopSpec spec;
  spec.setpoint_c = config.setpoint_c;
  config.observer = std::make_shared<const gyrotc::control::ObserverLoopDesign>(
      gyrotc::control::design_observer_loop(gyrotc::model::housing_model(gyrotc::model::PlantParams{}), spec));
  config.pid.period_s = spec.period_s;
  Harness observer(config);
  CHECK(std::isnan(observer.controller.loop_estimate().held_c));  // before its first period
  observer.controller.on_ambient_temperature(good(20.0, 0.0), 0.0);
  observer.run_for(10.0, 50.0, true, false);
  const LoopEstimate e = observer.controller.loop_estimate();
  CHECK(e.held_c == Approx(50.0).margin(0.5));
  CHECK(std::isfinite(e.ambient_c));
  CHECK(std::isfinite(e.holding_a));
}
