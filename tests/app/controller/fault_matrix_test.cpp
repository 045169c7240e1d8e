// The fault matrix (runtime/fault_matrix, docs/FAULTS.md) as the controller
// carries it out: each flag raised by its fault, on a controller holding a
// casing, and the TEC path and the rate output doing what the matrix says.
#include "gyrotc/app/runtime/fault_matrix.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <functional>
#include <string>
#include <utility>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc_catch.hpp"
#include "misconfigured_loop.hpp"

using namespace gyrotc::app;
using gyrotc::hal::AdcSample;
using gyrotc::hal::TempFault;
using gyrotc::hal::TemperatureReading;

namespace {

// What the board does in one second of a fault (the rest as usual).
struct Injection {
  bool sample = true;           // an ADC sample (false: a DRDY timeout)
  bool clipped = false;         // the sample at the converter's full scale
  bool reading = true;          // a casing reading this second
  // The reading; NaN: the usual one.
  TemperatureReading casing{std::numeric_limits<double>::quiet_NaN(), 0.0, true, TempFault::none};
  bool opa548_shutdown = false;
  bool tec_write_ok = true;
  bool rate_dac_ok = true;
  bool ambient_valid = true;    // the ambient sensor's reading (one every 10 s)
};

// A controller holding 50 C readings (alternating one step) at the seed's
// 2 s period, as the runners drive it; `second` runs one second of board.
struct MatrixRig {
  gyrotc::fit::Compensator compensator{gyrotc::fit::BiasModel::paper_reference()};
  ControllerConfig config;
  Controller controller;
  double now_s = 0.0;
  SampleResult last_sample;

  explicit MatrixRig(ControllerConfig c = {}) : config(std::move(c)), controller(config, compensator) {}

  void second(const Injection& in) {
    now_s += 1.0;
    if (in.sample) {
      AdcSample s;
      s.gyro_mv = 80.0;
      s.clipped = in.clipped;
      last_sample = controller.on_sample(s, now_s);
      controller.on_rate_output(in.rate_dac_ok);
    } else {
      controller.on_adc_timeout(now_s);
    }
    if (static_cast<long>(now_s) % 10 == 0) {
      controller.on_ambient_temperature({20.0, now_s - 0.75, in.ambient_valid, in.ambient_valid ? TempFault::none
                                                                                                 : TempFault::crc},
                                        now_s);
    }
    if (in.reading) {
      TemperatureReading r = in.casing;
      if (std::isnan(r.temp_c)) r = {static_cast<long>(now_s) % 4 == 0 ? 50.0625 : 50.0, now_s, true, TempFault::none};
      r.time_s = now_s - 0.75;
      controller.on_temperature(r, now_s);
    }
    if (static_cast<long>(now_s) % 2 == 0) {
      controller.on_opa548_thermal(in.opa548_shutdown, now_s);
      const TecCommand c = controller.on_pid_tick(now_s);
      controller.on_tec_applied(in.tec_write_ok || !c.enable, now_s);
    }
  }
  void run(double seconds, const Injection& in) {
    for (double t = 0.0; t < seconds - 1e-9; t += 1.0) second(in);
  }
};

TemperatureReading reading_of(double temp_c, bool valid = true, TempFault fault = TempFault::none) {
  return {temp_c, 0.0, valid, fault};
}

// How each flag's fault is made on the rig, long enough to be raised.
void inject(MatrixRig& rig, std::uint32_t flag) {
  const FailSafeLimits& l = rig.config.limits;
  Injection in;
  switch (flag) {
    case kFlagTempStale:
      in.reading = false;
      rig.run(l.stale_periods * rig.config.pid.period_s + 4.0, in);
      return;
    case kFlagTempInvalid:
      in.casing = reading_of(0.0, false, TempFault::crc);
      rig.run(2.0, in);
      return;
    case kFlagTempStuck:
      // Far from the setpoint the loop drives hard; the reading never moves.
      in.casing = reading_of(35.0);
      rig.run(l.stuck_s + 6.0, in);
      return;
    case kFlagOverTempLatched:
      in.casing = reading_of(l.over_temp_c + 1.0);
      rig.run(4.0, in);
      return;
    case kFlagOpa548Thermal:
      in.opa548_shutdown = true;
      rig.run(4.0, in);
      return;
    case kFlagTecWriteFailed:
      in.tec_write_ok = false;
      rig.run(4.0, in);
      return;
    case kFlagAdcInvalid:
      in.clipped = true;
      rig.run(2.0, in);
      return;
    case kFlagAdcStalled:
      in.sample = false;
      rig.run(l.adc_stall_s + 4.0, in);
      return;
    case kFlagRateDacFailed:
      in.rate_dac_ok = false;
      rig.run(2.0, in);
      return;
    case kFlagAmbientStale:
      in.ambient_valid = false;
      rig.run(l.ambient_stale_s + 12.0, in);
      return;
    case kFlagLoopRunaway:
      // The rig's loop cools a casing below the setpoint, and it cools.
      for (double t = 0.0; t < l.runaway_s + 30.0; t += 1.0) {
        in.casing = reading_of(std::round((50.0 - t / 30.0) * 16.0) / 16.0);
        rig.second(in);
      }
      return;
    case kFlagModelClamped:
      in.casing = reading_of(-45.0);  // below the paper's calibration (-40 C), a valid reading
      rig.run(4.0, in);
      return;
    default: FAIL("no way to make " << flag_name(flag) << " on the rig: add one");
  }
}

}  // namespace

TEST_CASE("every flag the journal tells has an entry in the fault matrix, and every entry is such a flag") {
  std::uint32_t entries = 0;
  for (const FaultEntry& e : fault_matrix()) {
    INFO(flag_name(e.flag));
    CHECK((kJournalFlags & e.flag) != 0);
    CHECK((entries & e.flag) == 0);  // one entry each
    CHECK(std::string(e.consequence).size() > 10);
    entries |= e.flag;
  }
  CHECK(entries == kJournalFlags);
}

TEST_CASE("each fault of the matrix stops what the matrix says and no more, on a controller holding a casing") {
  for (const FaultEntry& e : fault_matrix()) {
    DYNAMIC_SECTION(flag_name(e.flag)) {
      // A loop that cools below the setpoint (it holds against a 60 C room).
      MatrixRig rig(e.tec == TecPath::pid ? gyrotc::test::misconfigured_loop_config(-40.0, 60.0, 2.0)
                                          : ControllerConfig{});
      rig.run(20.0, {});
      const TecCommand before = rig.controller.last_command();
      REQUIRE(before.enable);
      inject(rig, e.flag);
      const std::uint32_t flags = rig.controller.flags();
      CHECK((flags & e.flag) != 0);
      const TecCommand& now = rig.controller.last_command();
      switch (e.tec) {
        case TecPath::drives: CHECK(now.enable); break;
        case TecPath::held:
          CHECK(now.enable);
          CHECK(now.current_a == before.current_a);
          break;
        case TecPath::off: CHECK_FALSE(now.enable); break;
        case TecPath::pid:
          CHECK(now.enable);
          CHECK(std::isnan(rig.controller.loop_estimate().held_c));  // no model-based loop runs
          break;
      }
      CHECK(((flags & kFlagUncontrolled) != 0) == (e.rate == RateOutputState::uncontrolled));
      switch (e.rate) {
        case RateOutputState::compensated:
        case RateOutputState::uncontrolled: CHECK(rig.last_sample.valid); break;
        case RateOutputState::clamped:
          CHECK(rig.last_sample.valid);
          CHECK((flags & kFlagModelClamped) != 0);
          break;
        case RateOutputState::invalid: CHECK((flags & kFlagAdcInvalid) != 0); break;
        case RateOutputState::stale: CHECK((flags & kFlagRateDacFailed) != 0); break;
      }
    }
  }
}

TEST_CASE("the fault matrix's Markdown has a row for each entry, the journal's words in it") {
  const std::string md = fault_matrix_markdown();
  for (const FaultEntry& e : fault_matrix()) {
    CHECK(md.find(std::string("| `") + flag_name(e.flag) + "` |") != std::string::npos);
    CHECK(md.find(e.consequence) != std::string::npos);
    CHECK(std::string(fault_consequence(e.flag)) == e.consequence);
  }
  CHECK(std::string(fault_consequence(kFlagTecSaturated)).empty());
}
