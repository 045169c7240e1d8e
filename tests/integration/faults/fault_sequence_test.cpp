// Fault sequences on the simulated board, lockstep (the runner gyrotc simulate
// uses, at 20 samples a second: the thermal loop is the subject, not the
// ADC): once every fault has cleared, the loop drives again and brings the
// casing back to the setpoint, whatever the faults did to the housing
// meanwhile.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc_catch.hpp"
#include "lockstep_board.hpp"

using namespace gyrotc;
using app::ControllerMode;

namespace {

constexpr double kSettleBandC = 0.3;  // the settle band of summarize_run (issue 4)

class SequenceRig {
 public:
  explicit SequenceRig(ControllerMode mode, double ambient_c = 16.0)
      : controller_config_(app::controller_preset(mode, plant_)),
        board_(test::plant_at(plant_, ambient_c), 1, test::lockstep_board_options(plant_)),
        compensator_(fit::BiasModel::paper_reference()),
        controller_(controller_config_, compensator_),
        profile_({{"hold", 0.0, 1e6, ambient_c, ambient_c}}),
        runner_(board_, controller_, profile_) {
    runner_.on_record([this](const app::RecordRow& row) {
      rows_.push_back(row);
      // The current the status and the rows report, against the stage, once
      // E/S can tell: a row in the same instant as the period that enabled
      // the stage (the sense still settling, app::kEsSenseSettleS) reports
      // the command whether or not the OPA548 was already in shutdown.
      const bool sense_settled = row.time_s - controller_.tec_enabled_since_s() >= app::kEsSenseSettleS;
      if (controller_.reported_tec_a() != 0.0 && !board_.opa548_chip().output_enabled() && sense_settled) {
        ++phantom_current_rows_;
      }
    });
  }

  void run_until(double t_s) { runner_.run_until(t_s); }
  void inject(hal::SimTempFault fault) { board_.inject_casing_sensor_fault(fault); }
  double setpoint_c() const { return controller_config_.setpoint_c; }
  hal::SimBoard& board() { return board_; }

  // The first time from which the true casing stays within the settle band
  // up to the end of the run (NaN: it does not).
  double settled_since_s(double from_s) const {
    double since = std::nan("");
    for (const auto& row : rows_) {
      if (row.time_s < from_s) continue;
      if (std::fabs(row.casing_c - setpoint_c()) > kSettleBandC) {
        since = std::nan("");
      } else if (std::isnan(since)) {
        since = row.time_s;
      }
    }
    return since;
  }
  const app::RecordRow& last_row() const { return rows_.back(); }
  // Rows at which the controller reported a TEC current the OPA548 did not drive.
  int phantom_current_rows() const { return phantom_current_rows_; }

 private:
  model::PlantParams plant_;
  app::ControllerConfig controller_config_;
  hal::SimBoard board_;
  fit::Compensator compensator_;
  app::Controller controller_;
  model::ChamberProfile profile_;
  app::LockstepRunner runner_;
  std::vector<app::RecordRow> rows_;
  int phantom_current_rows_ = 0;
};

}  // namespace

// The virtual board's sequence (issue 75): settled at 55 C, one 85 C
// power-on value, then the bus held low (all-zero scratchpads, a valid CRC).
// The TEC goes safe at the stale limit; once the sensor reads again the PID
// must restart with what it had learnt of the hold (its integral) and act on
// the casing's fall, not take the fallen casing for the setpoint. The bus is
// held low for 120 s here: on this plant 30 s cool the casing by 0.3 C only,
// inside the separation band, where the integral repairs any restart; the
// virtual board's casing had fallen further, and the tuned PID held it 1.3 C
// low for good (the check below fails so with a restart from the output).
TEST_CASE("fault sequence: an 85 C power-on value then the 1-Wire bus held low, and the loop settles again") {
  for (const ControllerMode mode : {ControllerMode::paper, ControllerMode::tuned}) {
    CAPTURE(app::to_string(mode));
    SequenceRig rig(mode);
    rig.run_until(1800.0);
    REQUIRE(rig.settled_since_s(1200.0) <= 1500.0);  // held before the faults
    rig.inject(hal::SimTempFault::power_on_reset);   // the next conversion only
    rig.run_until(1803.0);
    rig.inject(hal::SimTempFault::all_zero);
    rig.run_until(1923.0);
    CHECK((rig.last_row().flags & app::kFlagTecOff) != 0);  // safe at the stale limit
    CHECK(rig.last_row().casing_c < rig.setpoint_c() - 0.75);  // fallen beyond the separation band
    rig.inject(hal::SimTempFault::none);
    rig.run_until(2800.0);
    // Back within the band and held there, within 600 s of the sensor's return.
    CHECK(rig.settled_since_s(1923.0) <= 1923.0 + 600.0);
    CHECK((rig.last_row().flags & app::kFlagTecOff) == 0);
  }
}

namespace {

// One fault of a random sequence: what, from when, for how long.
struct FaultSpan {
  enum class Kind { casing_sensor, ambient_sensor, drdy_stall, opa548_shutdown, adc_spi, rate_dac_spi, tec_dac_spi };
  Kind kind = Kind::casing_sensor;
  hal::SimTempFault sensor_fault = hal::SimTempFault::none;
  double onset_s = 0.0;
  double end_s = 0.0;
};

std::vector<FaultSpan> random_sequence(std::mt19937_64& rng, double from_s, double to_s) {
  constexpr hal::SimTempFault kSensorFaults[] = {
      hal::SimTempFault::disconnect, hal::SimTempFault::crc_error, hal::SimTempFault::stuck,
      hal::SimTempFault::power_on_reset, hal::SimTempFault::all_zero, hal::SimTempFault::low_resolution};
  constexpr FaultSpan::Kind kDeviceFaults[] = {FaultSpan::Kind::ambient_sensor, FaultSpan::Kind::drdy_stall,
                                               FaultSpan::Kind::opa548_shutdown, FaultSpan::Kind::adc_spi,
                                               FaultSpan::Kind::rate_dac_spi, FaultSpan::Kind::tec_dac_spi};
  std::uniform_int_distribution<int> count(1, 5);
  // The casing sensor's faults as often as all the others together.
  std::uniform_int_distribution<std::size_t> kind(0, 2 * std::size(kDeviceFaults) - 1);
  std::uniform_int_distribution<std::size_t> sensor(0, std::size(kSensorFaults) - 1);
  std::uniform_real_distribution<double> onset(from_s, to_s);
  std::uniform_real_distribution<double> duration(1.0, 240.0);
  std::vector<FaultSpan> spans(static_cast<std::size_t>(count(rng)));
  for (FaultSpan& f : spans) {
    const std::size_t k = kind(rng);
    f.kind = k < std::size(kDeviceFaults) ? kDeviceFaults[k] : FaultSpan::Kind::casing_sensor;
    if (f.kind == FaultSpan::Kind::casing_sensor || f.kind == FaultSpan::Kind::ambient_sensor) {
      f.sensor_fault = kSensorFaults[sensor(rng)];
    }
    f.onset_s = onset(rng);
    f.end_s = f.onset_s + duration(rng);
  }
  return spans;
}

// Applies the sequence second by second: overlapping spans overlap (a later
// sensor fault replaces an earlier one on the one chip while both last).
// Returns when the last fault cleared.
double play(SequenceRig& rig, const std::vector<FaultSpan>& spans) {
  double first_s = 1e300;
  double last_s = 0.0;
  for (const FaultSpan& f : spans) {
    first_s = std::min(first_s, f.onset_s);
    last_s = std::max(last_s, f.end_s);
  }
  const double start_s = std::floor(first_s);
  for (double t = start_s; t <= last_s + 1.0; t += 1.0) {
    hal::SimTempFault casing = hal::SimTempFault::none;
    hal::SimTempFault ambient = hal::SimTempFault::none;
    double casing_onset_s = -1.0;
    double ambient_onset_s = -1.0;
    bool on[7] = {};
    for (const FaultSpan& f : spans) {
      if (t < f.onset_s || t >= f.end_s) continue;
      on[static_cast<int>(f.kind)] = true;
      if (f.kind == FaultSpan::Kind::casing_sensor && f.onset_s > casing_onset_s) {
        casing = f.sensor_fault;
        casing_onset_s = f.onset_s;
      }
      if (f.kind == FaultSpan::Kind::ambient_sensor && f.onset_s > ambient_onset_s) {
        ambient = f.sensor_fault;
        ambient_onset_s = f.onset_s;
      }
    }
    const auto is_on = [&on](FaultSpan::Kind k) { return on[static_cast<int>(k)]; };
    rig.inject(casing);
    rig.board().inject_ambient_sensor_fault(ambient);
    rig.board().inject_drdy_stall(is_on(FaultSpan::Kind::drdy_stall));
    rig.board().inject_opa548_thermal_shutdown(is_on(FaultSpan::Kind::opa548_shutdown));
    rig.board().inject_spi_error(is_on(FaultSpan::Kind::adc_spi));
    rig.board().inject_rate_dac_spi_error(is_on(FaultSpan::Kind::rate_dac_spi));
    rig.board().inject_tec_dac_spi_error(is_on(FaultSpan::Kind::tec_dac_spi));
    rig.run_until(t + 1.0);
  }
  return last_s;
}

}  // namespace

// No fault sequence leaves the loop off: random onsets, durations, overlaps
// and recoveries of every fault of both DS18B20s, a stopped DRDY, an OPA548
// shutdown and an SPI error on each of the three devices, on a casing held at
// 55 C; once all have cleared the TEC drives again and the casing is back
// within the settle band within kRecoveryS (the OPA548's 60 s cool-down and a
// warm-up from wherever the faults left the casing), and no row meanwhile
// reported a TEC current the stage was not driving.
TEST_CASE("fault sequence: after any random sequence of sensor and device faults the loop drives and settles again") {
  constexpr double kRecoveryS = 900.0;
  for (const ControllerMode mode : {ControllerMode::paper, ControllerMode::tuned}) {
    for (std::uint64_t seed = 1; seed <= 12; ++seed) {
      CAPTURE(app::to_string(mode), seed);
      std::mt19937_64 rng(seed);
      const std::vector<FaultSpan> spans = random_sequence(rng, 1800.0, 2300.0);
      SequenceRig rig(mode);
      rig.run_until(1800.0);
      REQUIRE(rig.settled_since_s(1200.0) <= 1500.0);
      const double cleared_s = play(rig, spans);
      rig.run_until(cleared_s + kRecoveryS + 300.0);
      CHECK((rig.last_row().flags & app::kFlagTecOff) == 0);
      CHECK(rig.settled_since_s(cleared_s) <= cleared_s + kRecoveryS);
      CHECK(rig.phantom_current_rows() == 0);
    }
  }
}
