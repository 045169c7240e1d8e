#include "gyrotc/app/runtime/lockstep_runner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/app/runtime/record_columns.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"

namespace gyrotc::app {

LockstepRunner::LockstepRunner(hal::SimBoard& board, Controller& controller,
                               const model::ChamberProfile& profile, const LockstepOptions& options)
    : board_(board),
      devices_(board.board()),
      controller_(controller),
      profile_(profile),
      options_(options),
      adc_timeout_s_(options.adc_timeout_periods * board.adc_chip().sample_period_s()),
      ambient_reading_c_(std::numeric_limits<double>::quiet_NaN()) {
  if (board.options().realtime) throw std::invalid_argument("the lockstep runner needs a lockstep SimBoard");
  const double t0 = devices_.clock.now_s();
  board_.set_ambient_c(profile_.ambient_c(t0));
  (void)devices_.tec.safe_off();
  sensor_c_ = board_.plant().sensor_c();
  next_ambient_s_ = t0;
  next_conversion_s_ = t0;
  next_pid_s_ = t0 + controller_.config().pid.period_s;
  next_record_s_ = t0 + options_.record_period_s;
  next_event_s_ = t0;
}

double LockstepRunner::now_s() const noexcept { return devices_.clock.now_s(); }

void LockstepRunner::run_until(double until_s, const std::function<void(double)>& progress) {
  const double start_s = now_s();
  const double span_s = until_s - start_s;
  double next_progress_s = start_s;
  double now = start_s;
  while (now < until_s) {
    auto sample = devices_.adc.read(adc_timeout_s_);
    if (sample.ok()) {
      now = sample->time_s;  // the DRDY edge: the virtual clock stands there
      ++counters_.samples;
      const SampleResult r = run_sample_tick(controller_, devices_.rate_dac, *sample, now, row_sums_);
      if (sample_hook_) sample_hook_(now, r);
    } else {
      now = devices_.clock.now_s();
      ++counters_.adc_timeouts;
      run_adc_timeout_tick(controller_, devices_.rate_dac, now, row_sums_);
      // A stalled DRDY must not stall virtual time: move on by a timeout.
      if (devices_.clock.now_s() <= now) board_.advance_to(now + adc_timeout_s_);
      now = devices_.clock.now_s();
    }
    if (now >= next_event_s_) handle_events(now);
    if (progress && span_s > 0.0 && now >= next_progress_s) {
      progress(std::clamp((now - start_s) / span_s, 0.0, 1.0));
      next_progress_s += span_s / 100.0;
    }
  }
}

void LockstepRunner::handle_events(double now) {
  if (now >= next_ambient_s_) {
    board_.set_ambient_c(profile_.ambient_c(now));
    while (next_ambient_s_ <= now) next_ambient_s_ += options_.ambient_update_s;
  }
  if (delivery_s_ >= 0.0 && now >= delivery_s_) {
    controller_.on_temperature(casing_in_flight_, now);
    if (casing_in_flight_.valid) sensor_c_ = casing_in_flight_.temp_c;
    if (devices_.ambient_sensor != nullptr) {
      controller_.on_ambient_temperature(ambient_in_flight_, now);
      if (ambient_in_flight_.valid) ambient_reading_c_ = ambient_in_flight_.temp_c;
    }
    ++counters_.readings;
    delivery_s_ = -1.0;
  }
  if (now >= next_conversion_s_) {
    // The lockstep DS18B20 returns the temperature of this instant; the
    // conversion time passes before the controller sees it. The sensor cycle
    // keeps the schedule of ambient_conversion_due, as the real-time runner
    // does: on its turn the ambient converts first and the casing after it.
    const double scheduled_s = next_conversion_s_;
    if (devices_.ambient_sensor != nullptr && ambient_conversion_due(conversions_) && !ambient_converted_) {
      ambient_in_flight_ = devices_.ambient_sensor->read();
      ++counters_.ambient_readings;
      ambient_converted_ = true;
      next_conversion_s_ = scheduled_s + options_.conversion_s;
    } else {
      casing_in_flight_ = devices_.casing_sensor.read();
      delivery_s_ = now + options_.conversion_s;
      const double cycle_start_s = ambient_converted_ ? scheduled_s - options_.conversion_s : scheduled_s;
      ambient_converted_ = false;
      ++conversions_;
      // The next cycle starts a period after this one, or when this one ends
      // if it overran (the ambient's turn): no catching up in a burst.
      next_conversion_s_ = std::max(cycle_start_s + options_.sensor_period_s, delivery_s_);
      while (next_conversion_s_ <= now) next_conversion_s_ += options_.sensor_period_s;
    }
  }
  if (now >= next_pid_s_) {
    const TecCommand command = run_pid_tick(controller_, devices_.tec, now);
    ++counters_.pid_ticks;
    saturated_ = saturated_ || (command.flags & kFlagTecSaturated) != 0;
    row_sums_.flags |= command.flags;
    if (pid_hook_) pid_hook_(now, command);
    while (next_pid_s_ <= now) next_pid_s_ += controller_.config().pid.period_s;
  }
  saturated_ = saturated_ || board_.plant().tec_limited();
  if (now >= next_record_s_) {
    run_thermal_poll(controller_, devices_.tec, now);
    emit_record(now);
    while (next_record_s_ <= now) next_record_s_ += options_.record_period_s;
  }
  next_event_s_ = std::min({next_ambient_s_, next_conversion_s_, next_pid_s_, next_record_s_,
                            delivery_s_ >= 0.0 ? delivery_s_ : std::numeric_limits<double>::infinity()});
}

void LockstepRunner::emit_record(double now) {
  const model::Plant& plant = board_.plant();
  RecordRow row;
  row.time_s = now;
  row.ambient_c = profile_.ambient_c(now);
  row.sensor_c = sensor_c_;
  row.casing_c = plant.controlled_c();
  row.die_c = plant.die_c();
  row.tec_v = plant.tec_voltage_v();
  row.tec_a = plant.tec_current_a();
  row.tec_command_a = controller_.reported_tec_a();
  row.ambient_reading_c = ambient_reading_c_;
  row.setpoint_c = controller_.active_setpoint_c();
  row.gyro_mv = row_sums_.mean_gyro_mv();
  row.rate_dps_compensated = row_sums_.mean_rate_dps();
  row.tec_saturated = saturated_;
  row.flags = row_sums_.flags | controller_.flags();
  row_sums_ = RowAccumulator{};
  saturated_ = false;
  if (record_hook_) record_hook_(row);
}

}  // namespace gyrotc::app

namespace gyrotc::app {

ControllerMode parse_controller_mode(const std::string& name) {
  if (name == "paper") return ControllerMode::paper;
  if (name == "tuned") return ControllerMode::tuned;
  if (name == "off") return ControllerMode::off;
  if (name == "oracle") return ControllerMode::oracle;
  throw InputError("unknown controller '" + name + "' (expected paper, tuned, off or oracle)");
}

const char* to_string(ControllerMode mode) noexcept {
  switch (mode) {
    case ControllerMode::paper: return "paper";
    case ControllerMode::tuned: return "tuned";
    case ControllerMode::off: return "off";
    case ControllerMode::oracle: return "oracle";
  }
  return "?";
}

ControllerConfig controller_preset(ControllerMode mode, const model::PlantParams& plant) {
  ControllerConfig config;  // seed Section 6: setpoint 55 C; Eq. 17/18 gains
  config.pid.out_min = -plant.current_limit_a;
  config.pid.out_max = plant.current_limit_a;
  if (mode == ControllerMode::off) config.pid_enabled = false;
  if (mode == ControllerMode::tuned) {
    // Ours (docs/GUIDE.md "Simulation"): the seed's integral-separated PID
    // structure, retuned for this plant, plus feed-forward from the ambient
    // DS18B20. KD 4 instead of 10: the seed's KD turns every 0.0625 C DS18B20
    // step into a 0.6 A kick, the main source of its in-band error. Kp 1.0
    // and xi 1 C brake the warm-up later and enter the integral band sooner;
    // KI 0.05 integrates gently over the wider band. Feed-forward 0.0048 A/C:
    // the plant's steady holding current per degree of (setpoint - ambient)
    // (0.36 A at -20 C ambient in the paper run).
    config.pid = control::PidParams::from_gains(1.0, 0.05, 4.0, 2.0);
    config.pid.xi_c = 1.0;
    config.pid.out_min = -plant.current_limit_a;
    config.pid.out_max = plant.current_limit_a;
    config.feed_forward_a_per_c = 0.0048;
  }
  if (mode == ControllerMode::oracle) {
    control::ObserverLoopSpec spec;
    spec.setpoint_c = config.setpoint_c;
    spec.reading_noise_c = plant.network ? plant.network->casing_sensor.noise_c : 0.0;
    spec.ambient_noise_c = plant.network ? plant.network->ambient_sensor.noise_c : 0.0;
    const control::HousingModel housing = model::housing_model(plant);
    config.observer =
        std::make_shared<const control::ObserverLoopDesign>(control::design_observer_loop(housing, spec));
    config.pid.period_s = spec.period_s;
    // The loop that knows the plant knows its holding currents too: the
    // stuck-sensor check's threshold above them, as tune sets it from a
    // record (fig26's -30..45 C), so that a reading held on one step is not
    // taken for a stuck sensor.
    double max_holding_a = 0.0;
    for (double ambient_c = -30.0; ambient_c <= 45.0; ambient_c += 5.0) {
      const double h = control::holding_current_a(housing, config.setpoint_c, ambient_c, plant.current_limit_a);
      if (std::isfinite(h)) max_holding_a = std::max(max_holding_a, std::fabs(h));
    }
    config.limits.stuck_min_drive_a = control::stuck_drive_threshold_a(max_holding_a, plant.current_limit_a);
  }
  return config;
}

RunSummary summarize_run(const std::vector<RecordRow>& rows, const model::ChamberProfile& profile,
                         double setpoint_c, double scale_mv_per_dps, double settle_band_c,
                         double settle_hold_s) {
  RunSummary summary;
  if (rows.empty()) return summary;
  summary.simulated_s = rows.back().time_s - profile.start_s();

  double run_start = -1.0;
  for (const auto& row : rows) {
    if (std::fabs(row.casing_c - setpoint_c) <= settle_band_c) {
      if (run_start < 0.0) run_start = row.time_s;
      if (row.time_s - run_start >= settle_hold_s) {
        summary.settle_s = run_start - profile.start_s();
        break;
      }
    } else {
      run_start = -1.0;
    }
  }
  // "After settling": once the hold that proves settling is over; the hold
  // itself starts at the band's edge, which would make every in-band maximum
  // read settle_band_c.
  const bool settled = summary.settle_s >= 0.0;
  const double settled_at = profile.start_s() + summary.settle_s + settle_hold_s;

  for (const auto& row : rows) {
    if (settled && row.time_s >= settled_at && row.ambient_c >= -20.0 && row.ambient_c <= 35.0) {
      summary.max_abs_error_c_in_band =
          std::max(summary.max_abs_error_c_in_band, std::fabs(row.casing_c - setpoint_c));
    }
  }

  const auto& segments = profile.segments();
  for (const auto& seg : segments) {
    SegmentSummary s;
    s.segment = seg.name;
    s.ambient_start_c = seg.ambient_start_c;
    s.ambient_end_c = seg.ambient_end_c;
    const bool before_settling = !settled || seg.end_s <= settled_at;
    const double from_s = before_settling ? seg.start_s : std::max(seg.start_s, settled_at);
    const double half_s = 0.5 * (seg.start_s + seg.end_s);
    double unc_sum = 0.0;
    double comp_sum = 0.0;
    std::size_t unc_n = 0;
    std::size_t comp_n = 0;
    for (const auto& row : rows) {
      if (row.time_s <= seg.start_s || row.time_s > seg.end_s) continue;
      s.tec_saturated = s.tec_saturated || row.tec_saturated;
      if (row.time_s >= from_s) {
        s.max_abs_error_c = std::max(s.max_abs_error_c, std::fabs(row.casing_c - setpoint_c));
      }
      if (seg.is_hold() && row.time_s >= half_s) {
        if (std::isfinite(row.gyro_mv)) {
          unc_sum += row.gyro_mv / scale_mv_per_dps;
          ++unc_n;
        }
        if (std::isfinite(row.rate_dps_compensated)) {
          comp_sum += row.rate_dps_compensated;
          ++comp_n;
        }
      }
    }
    if (unc_n > 0 && comp_n > 0) {
      s.has_bias = true;
      s.bias_uncompensated_dps = unc_sum / static_cast<double>(unc_n);
      s.bias_compensated_dps = comp_sum / static_cast<double>(comp_n);
      summary.bias_uncompensated_max_abs_dps =
          std::max(summary.bias_uncompensated_max_abs_dps, std::fabs(s.bias_uncompensated_dps));
      summary.bias_compensated_max_abs_dps =
          std::max(summary.bias_compensated_max_abs_dps, std::fabs(s.bias_compensated_dps));
    }
    summary.segments.push_back(std::move(s));
  }
  return summary;
}

void add_calibration_error(RunSummary& summary, const std::vector<RecordRow>& rows,
                           const model::ChamberProfile& profile, const model::PlantParams& plant,
                           double scale_mv_per_dps) {
  const auto& segments = profile.segments();  // summarize_run's order, one summary each
  for (std::size_t i = 0; i < summary.segments.size() && i < segments.size(); ++i) {
    SegmentSummary& s = summary.segments[i];
    const model::ProfileSegment* seg = &segments[i];
    if (!s.has_bias) continue;
    const double half_s = 0.5 * (seg->start_s + seg->end_s);
    double sum = 0.0;
    std::size_t n = 0;
    for (const auto& row : rows) {
      if (row.time_s < half_s || row.time_s > seg->end_s || !std::isfinite(row.die_c) ||
          !std::isfinite(row.gyro_mv) || !std::isfinite(row.rate_dps_compensated)) {
        continue;
      }
      // The compensated rate less what the gyro added to its curve at the
      // die (noise, named effects): the curve less the calibration at the
      // temperature the Controller compensated at.
      const double added_mv = row.gyro_mv - plant.zero_bias.bias_mv(row.die_c) - plant.zero_rate_offset_mv;
      sum += row.rate_dps_compensated - added_mv / scale_mv_per_dps;
      ++n;
    }
    if (n == 0) continue;
    s.calibration_error_dps = sum / static_cast<double>(n);
    summary.calibration_error_max_abs_dps =
        std::max(summary.calibration_error_max_abs_dps, std::fabs(s.calibration_error_dps));
  }
}

std::function<void(hal::SimBoard&, const RecordRow&)> freeze_casing_sensor_at(double at_s) {
  return [at_s, frozen = false](hal::SimBoard& board, const RecordRow& row) mutable {
    if (!frozen && row.time_s >= at_s) {
      board.inject_casing_sensor_fault(hal::SimTempFault::stuck);
      frozen = true;
    }
  };
}

SimulationResult run_simulation(const SimulationSetup& setup, const model::ChamberProfile& profile,
                                const std::function<void(double)>& progress) {
  if (setup.calibration == nullptr) throw std::invalid_argument("run_simulation needs a calibration");
  if (!(setup.sample_rate_hz > 0.0)) throw InputError("sample rate must be positive");
  model::PlantParams plant = setup.plant;
  plant.initial_temp_c = profile.ambient_c(profile.start_s());

  hal::SimBoardOptions options;
  options.realtime = false;
  options.thermal_step_s = plant.max_thermal_step_s;
  options.adc.fclk_hz = setup.sample_rate_hz * hal::Ads1251::kClocksPerSample;
  options.tec_current_limit_a = plant.current_limit_a;
  options.adc_model = setup.adc_model;
  // An ambient DS18B20 only for a controller that uses it (the seed's board had
  // none): on the shared bus it costs the casing sensor a slot every 10 s.
  options.ambient_sensor =
      setup.ambient_sensor.value_or(setup.controller.feed_forward_a_per_c > 0.0 || setup.program != nullptr ||
                                    setup.controller.observer != nullptr);
  hal::SimBoard board(plant, setup.seed, options);
  if (profile.start_s() > 0.0) board.advance_to(profile.start_s());

  const fit::Compensator compensator(*setup.calibration, setup.scale_mv_per_dps, setup.die_lag_s);
  Controller controller(setup.controller, compensator);
  LockstepRunner runner(board, controller, profile, setup.lockstep);

  SimulationResult result;
  const double span_s = profile.end_s() - profile.start_s();
  result.rows.reserve(static_cast<std::size_t>(span_s / setup.lockstep.record_period_s) + 2);
  runner.on_record([&result, &setup, &board](const RecordRow& row) {
    result.rows.push_back(row);
    if (setup.on_record) setup.on_record(board, row);
  });
  if (setup.on_sample) runner.on_sample(setup.on_sample);
  if (setup.program == nullptr) {
    runner.run_until(profile.end_s(), progress);
  } else {
    // In steps, to end with the programme.
    controller.run_program(setup.program);
    constexpr double kStepS = 10.0;
    while (runner.now_s() < profile.end_s() && !controller.program_finished()) {
      runner.run_until(std::min(profile.end_s(), runner.now_s() + kStepS));
      if (progress) progress(std::clamp((runner.now_s() - profile.start_s()) / span_s, 0.0, 1.0));
    }
  }
  result.counters = runner.counters();
  result.summary = summarize_run(result.rows, profile, setup.controller.setpoint_c,
                                 setup.scale_mv_per_dps);
  add_calibration_error(result.summary, result.rows, profile, plant, setup.scale_mv_per_dps);
  return result;
}

}  // namespace gyrotc::app

namespace gyrotc::app {

void write_records_csv(const std::vector<RecordRow>& rows, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw RuntimeFailure(path + ": cannot write the time series");
  std::fprintf(f,
               "time_s,ambient_c,sensor_c,casing_c,die_c,tec_v,tec_a,setpoint_c,gyro_mv,"
               "rate_dps_compensated,flags\n");
  for (const auto& r : rows) {
    std::fprintf(f, "%.3f,%.4f,%.4f,%.5f,%.5f,%.4f,%.5f,%.4f,%.5f,%.6f,%u\n", r.time_s, r.ambient_c,
                 r.sensor_c, r.casing_c, r.die_c, r.tec_v, r.tec_a, r.setpoint_c, r.gyro_mv,
                 r.rate_dps_compensated, static_cast<unsigned>(r.flags));
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) throw RuntimeFailure(path + ": cannot write the time series");
}

void write_board_record_csv(const std::vector<RecordRow>& rows, const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) throw RuntimeFailure(path + ": cannot write the record");
  std::fprintf(f, "%s\n", kRecordCsvHeader);
  char line[256];
  for (const auto& r : rows) {
    format_record_row(line, sizeof line, r.time_s, r.sensor_c, r.ambient_reading_c, r.gyro_mv, r.rate_dps_compensated,
                      r.tec_command_a, r.setpoint_c, r.flags);
    std::fprintf(f, "%s\n", line);
  }
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok) throw RuntimeFailure(path + ": cannot write the record");
}

}  // namespace gyrotc::app
