#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gyrotc/algorithms/model/chamber_profile.hpp"
#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/hal/sim/sim_board.hpp"

// The lockstep simulation runner: drives the real Controller through the
// SimBoard's Board devices (ADS1251 driver over the simulated DRDY/SPI,
// AD5060 frames to the plant, simulated DS18B20 files, OPA548 E/S) in virtual
// time, event by event, single-threaded and deterministic for a seed.
//
// Events, in virtual time:
//  - every ADC conversion (the DRDY wait moves the clock): Controller::on_sample,
//    the compensated rate to the rate DAC (or on_adc_timeout);
//  - every ambient_update_s: the chamber profile's ambient to the board;
//  - every sensor_period_s: a DS18B20 conversion starts (the reading reflects
//    that instant) and is delivered conversion_s later (on_temperature, with
//    on_ambient_temperature when the board has an ambient sensor, which
//    converts on the schedule of ambient_conversion_due);
//  - every PID period: the OPA548 thermal flag, Controller::on_pid_tick, and
//    the command applied (set_current_a + enable, or safe_off);
//  - every record_period_s: one RecordRow (temperatures and TEC now; gyro and
//    compensated rate averaged over the period).
namespace gyrotc::app {

struct LockstepOptions {
  double sensor_period_s = 1.0;    // one DS18B20 conversion per second
  double conversion_s = 0.75;      // DS18B20 datasheet: 12-bit conversion, max
  double ambient_update_s = 0.1;   // chamber ramps are 1 C/min: 0.002 C per update
  double record_period_s = 1.0;
  double adc_timeout_periods = 3.0;  // ADC wait timeout in sample periods
};

struct RecordRow {
  double time_s = 0.0;
  double ambient_c = 0.0;
  double sensor_c = 0.0;   // last casing reading delivered to the controller
  double casing_c = 0.0;   // true casing (Plant::controlled_c: with a network plant its sensor's node + offset)
  double die_c = 0.0;
  double tec_v = 0.0;
  double tec_a = 0.0;               // applied by the plant (after its limits and rails)
  double tec_command_a = 0.0;       // commanded by the controller (0 while off), as a board records it
  double ambient_reading_c = 0.0;   // last ambient DS18B20 reading delivered (NaN: none)
  double setpoint_c = 0.0;
  double gyro_mv = 0.0;                // mean over the record period
  double rate_dps_compensated = 0.0;   // mean over the record period (valid samples)
  bool tec_saturated = false;          // PID at its limit or the stage limited, during the period
  std::uint32_t flags = 0;             // controller flags, OR-ed over the period
};

struct RunCounters {
  std::uint64_t samples = 0;
  std::uint64_t adc_timeouts = 0;
  std::uint64_t pid_ticks = 0;
  std::uint64_t readings = 0;          // casing readings delivered
  std::uint64_t ambient_readings = 0;  // ambient conversions (ambient_conversion_due)
};

class LockstepRunner {
 public:
  using RecordHook = std::function<void(const RecordRow&)>;
  using PidHook = std::function<void(double now_s, const TecCommand&)>;
  using SampleHook = std::function<void(double now_s, const SampleResult&)>;

  // The board must be a lockstep SimBoard (options.realtime = false). All
  // three are referenced, not owned.
  LockstepRunner(hal::SimBoard& board, Controller& controller, const model::ChamberProfile& profile,
                 const LockstepOptions& options = {});

  // Called with every record row / after every PID tick (fault injection and
  // observation hooks for tests).
  void on_record(RecordHook hook) { record_hook_ = std::move(hook); }
  void on_pid_tick(PidHook hook) { pid_hook_ = std::move(hook); }
  // Called with every ADC sample's controller result (full-rate output for
  // noise analysis, `gyrotc simulate --rate-csv`).
  void on_sample(SampleHook hook) { sample_hook_ = std::move(hook); }

  // Runs until virtual time until_s; may be called again to continue.
  // progress (optional) is called about 100 times per run with the fraction done.
  void run_until(double until_s, const std::function<void(double)>& progress = {});

  hal::SimBoard& board() noexcept { return board_; }
  Controller& controller() noexcept { return controller_; }
  const RunCounters& counters() const noexcept { return counters_; }
  double now_s() const noexcept;

 private:
  void handle_events(double now_s);
  void emit_record(double now_s);

  hal::SimBoard& board_;
  hal::Board devices_;
  Controller& controller_;
  const model::ChamberProfile& profile_;
  LockstepOptions options_;
  RecordHook record_hook_;
  PidHook pid_hook_;
  SampleHook sample_hook_;
  RunCounters counters_;
  double adc_timeout_s_;

  double next_event_s_ = 0.0;
  double next_ambient_s_ = 0.0;
  double next_conversion_s_ = 0.0;
  double delivery_s_ = -1.0;  // < 0: no conversion in flight
  hal::TemperatureReading casing_in_flight_;
  hal::TemperatureReading ambient_in_flight_;  // goes out with casing_in_flight_
  std::uint64_t conversions_ = 0;              // casing conversions started
  bool ambient_converted_ = false;             // this cycle's ambient is done, the casing's is next
  double next_pid_s_ = 0.0;
  double next_record_s_ = 0.0;

  // Record accumulators.
  RowAccumulator row_sums_;
  bool saturated_ = false;
  double sensor_c_ = 0.0;
  double ambient_reading_c_;
};

// --- whole runs: presets, summary ------------------------------------------

enum class ControllerMode { paper, tuned, off, oracle };
ControllerMode parse_controller_mode(const std::string& name);  // InputError when unknown
const char* to_string(ControllerMode mode) noexcept;

// The controller of a mode for a plant (PID output limits = the plant's TEC
// current limit):
//  - paper: the seed's integral-separated PID (Eq. 17/18: Kp 0.48, KI 0.32,
//    KD 10, T 2 s, xi 0.5 C), setpoint 55 C;
//  - tuned: ours, see docs/GUIDE.md "Simulation";
//  - off: compensation only, the TEC stays off;
//  - oracle: the model-based loop designed on the plant's own housing (the
//    truth: model::housing_model), at a 1 s period: what a loop that knows
//    the plant holds, the reference others are judged against (issue 72).
ControllerConfig controller_preset(ControllerMode mode, const model::PlantParams& plant);

struct SegmentSummary {
  std::string segment;
  double ambient_start_c = 0.0;
  double ambient_end_c = 0.0;
  double max_abs_error_c = 0.0;  // |casing - setpoint| over the segment (after settling, if any)
  bool tec_saturated = false;
  // Hold segments: means over the second half of the segment.
  double bias_uncompensated_dps = 0.0;  // mean gyro_mv / scale (seed Table 2's bias_dps)
  double bias_compensated_dps = 0.0;    // mean compensated rate
  // The same mean compensated rate without what the gyro adds to its
  // zero-rate curve (its noise, the named effects): the plant's curve at the
  // die less the calibration where the Controller evaluated it (the
  // sensor's reading, through the calibration's die lag), over scale.
  double calibration_error_dps = 0.0;
  bool has_bias = false;
};

struct RunSummary {
  double simulated_s = 0.0;
  double settle_s = -1.0;               // < 0: never settled
  // True casing (RecordRow::casing_c), after settling (from settle_s + the settle hold on), while
  // the ambient is within [-20, 35] C (seed Section 6.2).
  double max_abs_error_c_in_band = 0.0;
  std::vector<SegmentSummary> segments;
  double bias_uncompensated_max_abs_dps = 0.0;
  double bias_compensated_max_abs_dps = 0.0;
  double calibration_error_max_abs_dps = 0.0;  // over the holds (SegmentSummary::calibration_error_dps)
};

// Settling: the first time after which |casing - setpoint| <= settle_band_c
// holds for settle_hold_s (issue 4: 0.3 C for 300 s).
RunSummary summarize_run(const std::vector<RecordRow>& rows, const model::ChamberProfile& profile,
                         double setpoint_c, double scale_mv_per_dps, double settle_band_c = 0.3,
                         double settle_hold_s = 300.0);

// Fills SegmentSummary::calibration_error_dps of every hold summarize_run
// gave a bias, and its maximum: each row's compensated rate less the gyro's
// output beyond the plant's zero-rate curve at the die (its offset
// included), averaged over the hold's second half. What the calibration
// leaves, with the sensor and its lag as the Controller saw them, and no
// gyro noise. A figure only a simulation has: on a board the curve is what
// the calibration estimates.
void add_calibration_error(RunSummary& summary, const std::vector<RecordRow>& rows,
                           const model::ChamberProfile& profile, const model::PlantParams& plant,
                           double scale_mv_per_dps);

struct SimulationSetup {
  model::PlantParams plant;
  std::uint64_t seed = 1;
  ControllerConfig controller;
  const fit::BiasModel* calibration = nullptr;  // required
  double scale_mv_per_dps = 8.774;              // seed Table 2 note
  double die_lag_s = 0.0;                       // the calibration's (fit::Compensator)
  double sample_rate_hz = 1000.0;
  LockstepOptions lockstep;
  LockstepRunner::SampleHook on_sample;  // optional, see LockstepRunner::on_sample
  // Optional: every record row with the board it came from (fault injection).
  std::function<void(hal::SimBoard&, const RecordRow&)> on_record;
  // Optional: a TEC programme in the PID's place (Controller::run_program);
  // the run ends when it finishes or the profile ends.
  control::TecProgram* program = nullptr;
  // The board has an ambient DS18B20 when the controller uses one (feed-
  // forward) or a programme runs (it records the ambient), unless set here.
  std::optional<bool> ambient_sensor;
  // The rate ADC's model (hal::SimAdcModel): transaction gives the bit-level
  // path's samples at under a third of its cost, since this reader is instant.
  hal::SimAdcModel adc_model = hal::SimAdcModel::transaction;
};

struct SimulationResult {
  std::vector<RecordRow> rows;
  RunSummary summary;
  RunCounters counters;
};

// Writes rows as CSV: time_s, ambient_c, sensor_c, casing_c, die_c, tec_v,
// tec_a, setpoint_c, gyro_mv, rate_dps_compensated, flags (the format
// `gyrotc fit` and `gyrotc identify` read). RuntimeFailure on a write error.
void write_records_csv(const std::vector<RecordRow>& rows, const std::string& path);

// Writes rows as the board's `gyrotc record` writes them (kRecordCsvHeader of
// record_columns.hpp): time_s, sensor_c, ambient_c (the ambient reading),
// gyro_mv, rate_dps_compensated, tec_a (commanded), setpoint_c, flags; no
// true temperature of the plant. RuntimeFailure on a write error.
void write_board_record_csv(const std::vector<RecordRow>& rows, const std::string& path);

// A SimulationSetup::on_record hook that freezes the casing sensor on its
// reading (hal::SimTempFault::stuck) from the first row at or after at_s.
std::function<void(hal::SimBoard&, const RecordRow&)> freeze_casing_sensor_at(double at_s);

// Builds a lockstep SimBoard (plant starting at the profile's first ambient),
// the Controller and the runner, runs the whole profile and summarises it.
SimulationResult run_simulation(const SimulationSetup& setup, const model::ChamberProfile& profile,
                                const std::function<void(double)>& progress = {});

}  // namespace gyrotc::app
