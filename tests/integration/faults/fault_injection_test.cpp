// Fault injection on the simulated board, lockstep: the real-time runner's
// loop body (RealtimeRunner::step) with the sensor thread's hand-over done
// once per simulated second, so every reaction is deterministic. For each
// fault: the TEC is at 0 A and the OPA548 disabled within one PID period,
// the output rows carry the flag, and recovery happens where it should.
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

namespace {

class Rig {
 public:
  Rig()
      : config_(app::load_daemon_config(gyrotc::test::config_file("gyrotc-sim.toml"))),
        instance_(app::make_board(config_.board, app::SimTiming::lockstep)),
        board_(instance_.board()),
        compensator_(fit::BiasModel::paper_reference()),
        controller_(config_.controller, compensator_),
        runner_(board_, controller_, options(config_)) {
    runner_.add_row_sink([this](const app::OutputRow& row) { row_flags_ |= row.flags; });
    runner_.prime();
  }

  // Runs for seconds of board time; the sensor is read once per second
  // unless `sensor` is false (a sensor thread that hangs).
  void run(double seconds, bool sensor = true) {
    const int per_second = static_cast<int>(std::lround(1.0 / sample_period_s()));
    for (int s = 0; s < static_cast<int>(std::lround(seconds)); ++s) {
      if (sensor) {
        hal::TemperatureReading casing = override_ ? override_(board_.casing_sensor.read())
                                                   : board_.casing_sensor.read();
        runner_.publish_readings(casing, board_.ambient_sensor->read());
      }
      for (int i = 0; i < per_second; ++i) runner_.step();
      runner_.drain();
    }
  }

  bool tec_off() const {
    const double mid_v = 0.5 * config_.board.devices.tec_dac.vref_v;
    return !sim().opa548_chip().output_enabled() && std::fabs(sim().tec_dac_chip().output_v() - mid_v) < 1e-3;
  }
  bool tec_driving() const { return sim().opa548_chip().output_enabled() && controller_.last_command().enable; }
  // Flags seen in the output rows since the last call.
  std::uint32_t take_row_flags() {
    const std::uint32_t f = row_flags_;
    row_flags_ = 0;
    return f;
  }

  hal::SimBoard& sim() { return *instance_.sim_board; }
  const hal::SimBoard& sim() const { return *instance_.sim_board; }
  app::Controller& controller() { return controller_; }
  app::RealtimeRunner& runner() { return runner_; }
  double pid_period_s() const { return config_.controller.pid.period_s; }
  double rate_mid_v() const { return 0.5 * config_.board.devices.rate_dac.vref_v; }
  // Replaces the casing reading the sensor thread hands over.
  std::function<hal::TemperatureReading(hal::TemperatureReading)> override_;

 private:
  static app::RealtimeRunnerOptions options(const app::DaemonConfig& c) {
    app::RealtimeRunnerOptions o;
    o.sample_period_s = hal::Ads1251::kClocksPerSample / c.board.devices.adc.fclk_hz;
    o.output_period_s = 1.0;
    return o;
  }
  double sample_period_s() const { return hal::Ads1251::kClocksPerSample / config_.board.devices.adc.fclk_hz; }

  app::DaemonConfig config_;
  app::BoardInstance instance_;
  hal::Board board_;
  fit::Compensator compensator_;
  app::Controller controller_;
  app::RealtimeRunner runner_;
  std::uint32_t row_flags_ = 0;
};

// Warm-up: readings arrive, the PID heats the 16 C casing towards 55 C.
void warm_up(Rig& rig) {
  rig.run(6.0);
  REQUIRE(rig.tec_driving());
  rig.take_row_flags();
}

}  // namespace

TEST_CASE("fault: ADC DRDY timeout flags the rate output invalid and puts the rate DAC at mid-scale") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_drdy_stall(true);
  for (int i = 0; i < 5; ++i) rig.runner().step();
  CHECK((rig.controller().flags() & app::kFlagAdcInvalid) != 0);
  CHECK(rig.runner().counters().adc_timeouts == 5);
  CHECK(rig.runner().counters().missed_drdy >= 5);  // missed conversions plus timeouts
  CHECK(rig.sim().rate_out_v() == Approx(rig.rate_mid_v()).margin(1e-3));  // rate DAC mid-scale: no rate
  rig.sim().inject_drdy_stall(false);
  rig.run(1.0);
  CHECK((rig.controller().flags() & app::kFlagAdcInvalid) == 0);
}

TEST_CASE("fault: a DRDY stall longer than adc_stall_s is flagged, the rate DAC sits at mid-scale and the TEC drives on") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_drdy_stall(true);
  rig.run(2.0);  // each step now waits out a 3-sample timeout: about 6 s of board time
  CHECK(rig.tec_driving());  // timeouts alone: the rate output is invalid, the temperature loop goes on
  rig.run(3.0);  // past failsafe.adc_stall_s (10 s)
  CHECK(rig.tec_driving());
  CHECK(rig.sim().rate_out_v() == Approx(rig.rate_mid_v()).margin(1e-3));
  const std::uint32_t flags = rig.take_row_flags();
  CHECK((flags & app::kFlagAdcStalled) != 0);
  CHECK((flags & (app::kFlagTecOff | app::kFlagUncontrolled)) == 0);
  rig.sim().inject_drdy_stall(false);
  rig.run(3.0);
  CHECK(rig.tec_driving());
  CHECK((rig.controller().flags() & app::kFlagAdcStalled) == 0);
}

TEST_CASE("fault: DS18B20 CRC errors hold the TEC current, then turn it off at the stale limit, good readings recover") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_casing_sensor_fault(hal::SimTempFault::crc_error);
  rig.run(1.0 + rig.pid_period_s());
  CHECK(rig.tec_driving());  // held: a CRC glitch is no reason for a thermal step
  CHECK((rig.take_row_flags() & app::kFlagTempInvalid) != 0);
  rig.run(3.0 * rig.pid_period_s());  // no valid reading for more than stale_periods
  CHECK(rig.tec_off());
  CHECK((rig.take_row_flags() & (app::kFlagTempStale | app::kFlagTecOff)) ==
        (app::kFlagTempStale | app::kFlagTecOff));
  rig.sim().inject_casing_sensor_fault(hal::SimTempFault::none);
  rig.run(3.0 + 2.0 * rig.pid_period_s());  // 3 good readings, then a tick
  CHECK(rig.tec_driving());
  CHECK((rig.controller().flags() & app::kFlagTempInvalid) == 0);
}

TEST_CASE("fault: one DS18B20 85 C power-on value is flagged invalid and the TEC current is held, not cut") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_casing_sensor_fault(hal::SimTempFault::power_on_reset);  // one reading
  rig.run(1.0 + rig.pid_period_s());
  CHECK(rig.tec_driving());
  CHECK((rig.take_row_flags() & (app::kFlagTempInvalid | app::kFlagTecOff)) == app::kFlagTempInvalid);
  rig.run(3.0 + 2.0 * rig.pid_period_s());
  CHECK(rig.tec_driving());
  CHECK((rig.controller().flags() & app::kFlagTempInvalid) == 0);
}

TEST_CASE("fault: a DS18B20 set to 9-bit resolution is refused as invalid, the TEC off at the stale limit") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_casing_sensor_fault(hal::SimTempFault::low_resolution);
  rig.run(1.0 + 4.0 * rig.pid_period_s());
  CHECK(rig.tec_off());
  CHECK((rig.take_row_flags() & app::kFlagTempInvalid) != 0);
}

TEST_CASE("fault: no casing reading for more than 3 PID periods (stale) turns the TEC off, then readings recover") {
  Rig rig;
  warm_up(rig);
  rig.run(3.0 * rig.pid_period_s() + 1.0 + rig.pid_period_s(), false);
  CHECK(rig.tec_off());
  CHECK((rig.take_row_flags() & app::kFlagTempStale) != 0);
  rig.run(3.0 + 2.0 * rig.pid_period_s());
  CHECK(rig.tec_driving());
}

TEST_CASE("fault: the OPA548 thermal flag turns the TEC off and is reported") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_opa548_thermal_shutdown(true);
  rig.run(rig.pid_period_s() + 1.0);
  CHECK(rig.tec_off());
  CHECK((rig.take_row_flags() & app::kFlagOpa548Thermal) != 0);
}

TEST_CASE("fault: casing over-temperature latches the TEC off even after good readings") {
  Rig rig;
  warm_up(rig);
  rig.override_ = [](hal::TemperatureReading r) {
    r.temp_c = 90.0;  // above failsafe.over_temp_c = 80 C, a valid DS18B20 value
    return r;
  };
  rig.run(1.0 + rig.pid_period_s());
  CHECK(rig.tec_off());
  CHECK((rig.take_row_flags() & app::kFlagOverTempLatched) != 0);
  rig.override_ = nullptr;
  rig.run(5.0 + 3.0 * rig.pid_period_s());
  CHECK(rig.tec_off());
  CHECK((rig.controller().flags() & app::kFlagOverTempLatched) != 0);
}

TEST_CASE("fault: the TEC DAC's SPI failing turns the TEC off within a PID period, named, reported at 0 A, and retried") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_tec_dac_spi_error(true);
  rig.run(rig.pid_period_s() + 1.0);
  CHECK_FALSE(rig.sim().opa548_chip().output_enabled());  // E/S low: the DAC's last code drives nothing
  CHECK((rig.controller().flags() & (app::kFlagTecWriteFailed | app::kFlagTecOff)) ==
        (app::kFlagTecWriteFailed | app::kFlagTecOff));
  // What the status line and the rows show: no current the stage is not driving.
  CHECK_FALSE(rig.controller().last_command().enable);
  CHECK(rig.controller().last_command().current_a == 0.0);
  CHECK(rig.runner().status().tec_a == 0.0);
  CHECK((rig.take_row_flags() & app::kFlagTecWriteFailed) != 0);
  rig.sim().inject_tec_dac_spi_error(false);
  rig.run(rig.pid_period_s() + 1.0);
  CHECK(rig.tec_driving());
  CHECK((rig.controller().flags() & app::kFlagTecWriteFailed) == 0);
}

TEST_CASE("fault: the rate DAC's SPI failing is named while the temperature loop goes on") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_rate_dac_spi_error(true);
  rig.run(1.0);
  CHECK((rig.controller().flags() & app::kFlagRateDacFailed) != 0);
  CHECK((rig.take_row_flags() & app::kFlagRateDacFailed) != 0);
  rig.run(2.0 * rig.pid_period_s());
  CHECK(rig.tec_driving());  // the TEC path needs no rate DAC
  rig.sim().inject_rate_dac_spi_error(false);
  rig.run(1.0);
  CHECK((rig.controller().flags() & app::kFlagRateDacFailed) == 0);
}

TEST_CASE("fault: the ambient DS18B20 unplugged is flagged ambient_stale, the TEC drives on, a reading clears it") {
  Rig rig;
  warm_up(rig);
  rig.sim().inject_ambient_sensor_fault(hal::SimTempFault::disconnect);
  rig.run(10.0);
  CHECK((rig.controller().flags() & app::kFlagAmbientStale) == 0);  // not yet: 10 s without a reading
  rig.run(20.0);  // past failsafe.ambient_stale_s (25 s)
  CHECK((rig.take_row_flags() & app::kFlagAmbientStale) != 0);
  CHECK(rig.tec_driving());
  CHECK((rig.controller().flags() & app::kFlagUncontrolled) == 0);
  rig.sim().inject_ambient_sensor_fault(hal::SimTempFault::none);
  rig.run(2.0);
  CHECK((rig.controller().flags() & app::kFlagAmbientStale) == 0);
}
