#include "gyrotc/app/daemon/session.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/calibrate/sweep_experiment.hpp"
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/app/formats/calibration_in_use.hpp"
#include "gyrotc/app/runtime/fault_matrix.hpp"
#include "gyrotc/app/runtime/kernel_rt.hpp"
#include "gyrotc/app/daemon/row_outputs.hpp"
#include "gyrotc/app/support/log.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"
#include "gyrotc/app/daemon/config_reload.hpp"
#include "gyrotc/app/daemon/signals.hpp"
#include "gyrotc/app/daemon/status_publisher.hpp"
#include "gyrotc/app/daemon/systemd_notify.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/output_path.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/linux/gpio_persistence.hpp"

namespace gyrotc::app {
namespace {

std::unique_ptr<fit::Compensator> make_compensator(CalibrationInUse c) {
  return std::make_unique<fit::Compensator>(std::move(c.model), c.scale_mv_per_dps, c.die_lag_s);
}

double us(double s) { return s * 1e6; }

// The controller's fault flags as the journal tells them: each one raised
// (a warning, what it means and what the controller does about it) and
// cleared (a notice), at most one raise a flag every 30 s (a flapping one
// would fill the journal), a clear only after a raise that was told.
class FaultReporter {
 public:
  void update(std::uint32_t flags, double now_s) {
    for (unsigned bit = 0; bit < 32; ++bit) {
      const std::uint32_t flag = 1u << bit;
      if ((kJournalFlags & flag) == 0) continue;
      const bool on = (flags & flag) != 0;
      const bool was = (told_ & flag) != 0;
      if (on && !was && now_s >= quiet_until_s_[bit]) {
        GYROTC_LOG_WARNING("fault %s: %s", flag_name(flag), fault_consequence(flag));
        told_ |= flag;
        quiet_until_s_[bit] = now_s + 30.0;
      } else if (!on && was) {
        GYROTC_LOG_NOTICE("fault %s cleared", flag_name(flag));
        told_ &= ~flag;
      }
    }
  }

 private:
  std::uint32_t told_ = 0;
  double quiet_until_s_[32] = {};
};

// Best effort on every path out: a second safe-off after the runner's is harmless.
class SafeOffGuard {
 public:
  explicit SafeOffGuard(hal::TecDriver& tec) : tec_(tec) {}
  ~SafeOffGuard() { (void)tec_.safe_off(); }
  SafeOffGuard(const SafeOffGuard&) = delete;
  SafeOffGuard& operator=(const SafeOffGuard&) = delete;

 private:
  hal::TecDriver& tec_;
};

double current_limit_a(const ControllerConfig& c) {
  return std::max(std::fabs(c.pid.out_min), std::fabs(c.pid.out_max));
}

// What the status says of this daemon from its start on.
StatusPublisherOptions status_options(const DaemonConfig& config, const std::string& experiment,
                                      const CalibrationInUse& calibration, double started_unix_s) {
  StatusPublisherOptions o;
  o.status_file = config.output.status_file;
  o.metrics_file = config.output.metrics_file;
  DaemonStatus& s = o.identity;
  s.pid = static_cast<int>(::getpid());
  s.hal = config.board.hal == HalKind::sim ? "sim" : "linux";
  s.config = config.source;
  s.mode = !experiment.empty() ? "experiment" : (config.controller.pid_enabled ? "pid" : "tec_off");
  s.experiment = experiment;
  s.started_unix_s = started_unix_s;
  s.tec_limit_a = current_limit_a(config.controller);
  set_status_calibration(s, calibration);
  return o;
}

}  // namespace

void safe_off_board(const DaemonConfig& config) {
  if (config.board.hal == HalKind::sim) {
    BoardInstance instance = make_board(config.board, SimTiming::lockstep);
    hal::Board board = instance.board();
    const hal::Status tec = board.tec.safe_off();
    (void)board.rate_dac.write_v(0.5 * config.controller.rate_dac_vref_v);
    if (!tec.ok()) throw RuntimeFailure("safe-off: the TEC stage did not accept 0 A / disable");
    return;
  }
  const hal::SafeOffReport report = hal::LinuxBoard::safe_off(config.board.devices);
  if (!report.rate_dac.ok()) {
    GYROTC_LOG_WARNING("safe-off: the rate DAC is not at mid-scale: %.*s",
                       static_cast<int>(report.rate_dac.error().message().size()),
                       report.rate_dac.error().message().data());
  }
  if (!report.tec_safe()) {
    const auto what = [](const hal::Status& s) { return s.ok() ? std::string("ok") : std::string(s.error().message()); };
    throw RuntimeFailure("safe-off: the TEC is not known to be safe: TEC DAC: " + what(report.tec_dac) +
                         "; OPA548 E/S: " + what(report.opa548));
  }
}

namespace {

// The self-calibration's progress, each status interval: what a user
// watching a 4 h run wants to know.
void log_sweep_progress(const calibrate::SweepExperiment& sweep, double casing_c) {
  const double left_s = sweep.remaining_s();
  char left[48] = "not known yet";
  if (std::isfinite(left_s)) std::snprintf(left, sizeof left, "about %.0f min", left_s / 60.0);
  const auto end = [](double c) {
    char text[16] = "-";
    if (std::isfinite(c)) std::snprintf(text, sizeof text, "%.1f C", c);
    return std::string(text);
  };
  char target[24] = "-";
  if (std::isfinite(sweep.target_c())) std::snprintf(target, sizeof target, "%.2f C", sweep.target_c());
  // In a dwell: why the end is still held (the gyro still settling).
  char trend[112] = "";
  const calibrate::SweepPhase phase = sweep.phase();
  const bool dwell = phase == calibrate::SweepPhase::dwell_low || phase == calibrate::SweepPhase::dwell_high;
  if (dwell && std::isfinite(sweep.gyro_trend_dps())) {
    std::snprintf(trend, sizeof trend, "; the gyro moved %.4f deg/s over the last %.0f s (the end turns within %.4f)",
                  sweep.gyro_trend_dps(), sweep.plan().settle_window_s, sweep.plan().settle_dps);
  }
  GYROTC_LOG_NOTICE("self-calibration: %s, casing %.2f C, target %s, ends reached: low %s, high %s; left %s%s",
                    calibrate::to_string(sweep.phase()), casing_c, target, end(sweep.reached_low_c()).c_str(),
                    end(sweep.reached_high_c()).c_str(), left, trend);
}

}  // namespace

std::string run_session(const SessionOptions& options) {
  DaemonConfig config = load_daemon_config(options.config_path);
  // What the daemon started with, for the keys a SIGHUP cannot apply (config_reload.hpp).
  const toml::table started_with = toml::parse_file(options.config_path);
  if (!options.controller_file.empty()) use_controller_file(config, options.controller_file);
  if (options.pid) config.controller.pid_enabled = *options.pid;
  const bool experiment_runs = options.tune_experiment || options.selfcal_experiment;
  if (options.tune_experiment && options.selfcal_experiment) {
    throw InputError("the identification experiment and the self-calibration sweep: one at a time");
  }
  if (options.selfcal_experiment && !config.controller.pid_enabled) {
    throw InputError("the self-calibration sweep drives the TEC: it cannot run with the PID (TEC) off");
  }
  if (options.tune_experiment && !config.controller.pid_enabled) {
    throw InputError("the identification experiment drives the TEC: it cannot run with the PID (TEC) off");
  }
  if (!options.record_csv.empty()) config.output.record_csv = options.record_csv;
  config.realtime.allow_non_rt = options.allow_non_rt;

  // A compensator a reload replaced stays alive until the loop has moved to
  // the new one (Controller::compensator_in_use): it may be in a sample with
  // the old one when the reload swaps them.
  std::vector<std::unique_ptr<fit::Compensator>> compensators;
  std::vector<std::unique_ptr<ControllerReload>> reloads;  // each SIGHUP's controller and loop, alive to the end
  CalibrationInUse calibration = load_calibration_in_use(config.calibration_file);
  compensators.push_back(make_compensator(calibration));
  Controller controller(config.controller, *compensators.back());
  tune::IdentificationExperiment experiment(tune::ExperimentPlan{}.scaled(options.experiment_scale));
  if (options.tune_experiment) controller.run_program(&experiment);
  calibrate::SweepExperiment sweep(calibrate::plan_below_over_temp(config.controller.limits.over_temp_c));
  if (options.selfcal_experiment) controller.run_program(&sweep);

  // Output files before any device: a bad path fails without touching the board.
  if (!options.summary_json.empty()) prepare_output_file(options.summary_json, "--summary-json");
  const auto outputs_config = [&options](const OutputConfig& output) {
    RowOutputsConfig c;
    c.output = output;
    if (!options.record_csv.empty()) c.output.record_csv = options.record_csv;
    c.stream = options.stream;
    // The daemon's own record rotates; `record --out`, a calibration run, is kept whole.
    c.rotate = options.record_csv.empty();
    c.record_key = options.record_csv.empty() ? "output.record_csv" : "--out";
    return c;
  };
  RowOutputs outputs(outputs_config(config.output));

  DaemonSignals signals;  // before any thread starts: every thread inherits the mask
  BoardInstance instance = make_board(config.board, SimTiming::realtime);
  hal::Board board = instance.board();
  SafeOffGuard guard(board.tec);
  if (!board.tec.senses_thermal()) {
    GYROTC_LOG_WARNING("OPA548 thermal state unknown: no E/S sense line ([devices.opa548] es_sense), so a thermal "
                       "shutdown cannot be seen and is not reported");
  }
  if (config.board.hal == HalKind::linux_devices && hal::gpio_outputs_persist().value_or(false)) {
    GYROTC_LOG_WARNING("this kernel keeps released GPIO outputs driving (%s = Y): if gyrotc dies outside systemd, "
                       "E/S stays where it was; set dtparam=strict_gpiod (docs/BOARD-rpi4.md)",
                       hal::kPersistGpioOutputsPath);
  }

  RealtimeRunnerOptions ro;
  ro.realtime = config.realtime;
  ro.duration_s = options.duration_s;
  if (options.tune_experiment) {
    const double bound_s = experiment.plan().max_duration_s() + 60.0;
    ro.duration_s = ro.duration_s > 0.0 ? std::min(ro.duration_s, bound_s) : bound_s;
  }
  if (options.selfcal_experiment) {
    // The sweep ends itself; this bounds it at the coldest ambient the
    // sensor reads, the range then the widest.
    const double bound_s = sweep.plan().max_duration_s({-55.0, sweep.plan().ceiling_c}) + 60.0;
    ro.duration_s = ro.duration_s > 0.0 ? std::min(ro.duration_s, bound_s) : bound_s;
  }
  ro.sample_period_s = hal::Ads1251::kClocksPerSample / config.board.devices.adc.fclk_hz;
  ro.output_period_s = config.output.period_s;
  ro.sensor_period_s = config.sensor_period_s;
  RealtimeRunner runner(board, controller, ro);
  // Headers with the first row: nothing is written when the start is refused.
  runner.add_row_sink([&outputs](const OutputRow& row) { outputs.write(row); });

  if (config.board.hal == HalKind::linux_devices) {
    const KernelRealtime kernel = running_kernel_realtime();
    if (!kernel.preempt_rt) {
      GYROTC_LOG_WARNING("the kernel is not PREEMPT_RT (%s): under load the DRDY-to-read latency can exceed the "
                         "ADS1251's DOUT window; late reads are counted (docs/BOARD-rpi4.md)",
                         kernel.evidence.c_str());
    }
  }
  runner.start();
  SystemdNotify notify;
  notify.ready();
  GYROTC_LOG_NOTICE("running on %s (%s): %s, memory %s, PID %s, calibration %s",
                    config.board.hal == HalKind::sim ? "the simulated board" : "the board", config.source.c_str(),
                    runner.is_realtime() ? "SCHED_FIFO" : "normal scheduler (--allow-non-rt)",
                    runner.memory_locked() ? "locked" : "not locked",
                    options.tune_experiment      ? "replaced by the identification experiment"
                    : options.selfcal_experiment ? "replaced by the self-calibration sweep"
                                                 : (config.controller.pid_enabled ? "on" : "off"),
                    describe(calibration).c_str());
  if (options.tune_experiment) {
    GYROTC_LOG_NOTICE("identification experiment: at most %.0f s; then `gyrotc tune --data %s --out controller.toml`",
                      experiment.plan().max_duration_s(), config.output.record_csv.c_str());
  }

  using clock = std::chrono::steady_clock;
  const auto started = clock::now();
  const auto unix_now_s = [] {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  };
  StatusPublisher publisher(
      status_options(config,
                     options.tune_experiment      ? "identification"
                     : options.selfcal_experiment ? "self-calibration"
                                                  : "",
                     calibration, unix_now_s()));
  auto next_publish = started;
  auto next_status = started + std::chrono::duration_cast<clock::duration>(
                                   std::chrono::duration<double>(config.output.status_interval_s));
  const double watchdog_s = notify.watchdog_interval_s().value_or(0.0);
  auto next_watchdog = started;
  std::uint64_t last_heartbeat = 0;
  int stop_signal = 0;
  FaultReporter faults;
  while (!runner.finished() && !controller.program_finished()) {
    const DaemonSignals::Event event = signals.wait(0.1);
    if (event == DaemonSignals::Event::stop) {
      stop_signal = signals.last_signal();
      break;
    }
    if (event == DaemonSignals::Event::reload) {
      try {
        ReloadPlan plan = plan_reload(options, started_with);
        // The outputs first: a path that cannot be written refuses the whole reload.
        const std::string outputs_changed = outputs.reconfigure(outputs_config(plan.config.output));
        if (!outputs_changed.empty()) GYROTC_LOG_NOTICE("SIGHUP: outputs reloaded: %s", outputs_changed.c_str());
        publisher.set_files(plan.config.output.status_file, plan.config.output.metrics_file);
        for (const std::string& key : plan.restart_keys) {
          GYROTC_LOG_WARNING("SIGHUP: %s changed in %s: it takes a restart (systemctl restart gyrotc); the running "
                             "value stays", key.c_str(), config.source.c_str());
        }
        const std::string text = describe(plan.calibration);
        publisher.set_calibration(plan.calibration);
        compensators.push_back(make_compensator(std::move(plan.calibration)));
        controller.set_compensator(*compensators.back());
        GYROTC_LOG_NOTICE("SIGHUP: calibration reloaded from %s", text.c_str());
        config.output.status_interval_s = plan.config.output.status_interval_s;
        const ControllerConfig& asked_before = reloads.empty() ? config.controller : reloads.back()->config;
        if (experiment_runs) {
          GYROTC_LOG_NOTICE("SIGHUP: an experiment drives the TEC: [control] not applied");
        } else {
          // Kept alive, with its model-based loop built here: the loop
          // thread takes it at its next PID period (Controller::request_reload).
          const bool new_loop = !same_model_based_loop(asked_before, plan.config.controller);
          reloads.push_back(std::make_unique<ControllerReload>(plan.config.controller));
          const ControllerConfig& c = reloads.back()->config;
          controller.request_reload(*reloads.back());
          publisher.set_control(c.pid_enabled ? "pid" : "tec_off", current_limit_a(c));
          if (c.observer) {
            GYROTC_LOG_NOTICE("SIGHUP: control reloaded (from the next PID period, bumpless): %s, setpoint %.2f C, "
                              "model-based loop (%d states)%s, period %g s, TEC %g .. %g A",
                              c.pid_enabled ? "on" : "TEC off", c.setpoint_c, c.observer->model.state_count(),
                              new_loop ? ", a new model or design taking over from the running loop" : "",
                              c.pid.period_s, c.pid.out_min, c.pid.out_max);
          } else {
            GYROTC_LOG_NOTICE("SIGHUP: control reloaded (from the next PID period, bumpless): %s, setpoint %.2f C, "
                              "Kp %g, TI %g s, TD %g s, period %g s, xi %g C, TEC %g .. %g A%s",
                              c.pid_enabled ? "PID" : "TEC off", c.setpoint_c, c.pid.kp, c.pid.ti_s, c.pid.td_s,
                              c.pid.period_s, c.pid.xi_c, c.pid.out_min, c.pid.out_max,
                              new_loop ? " (the PID taking over from the model-based loop)" : "");
          }
        }
      } catch (const std::exception& e) {
        GYROTC_LOG_ERROR("SIGHUP: nothing reloaded, the running configuration stays: %s", e.what());
      }
    }
    if (compensators.size() > 1 && controller.compensator_in_use() == compensators.back().get()) {
      compensators.erase(compensators.begin(), compensators.end() - 1);
    }
    const auto now = clock::now();
    const double uptime_s = std::chrono::duration<double>(now - started).count();
    faults.update(runner.status().flags, uptime_s);
    // Once a second, and at once when the first casing reading arrives (the state is known from then).
    const bool first_reading = std::isnan(publisher.status().casing_c) && std::isfinite(runner.status().casing_c);
    if (now >= next_publish || first_reading) {
      notify.status(publisher.update(runner.status(), runner.counters(), runner.latency(), uptime_s, unix_now_s()));
      if (now >= next_publish) next_publish += std::chrono::seconds(1);
    }
    if (watchdog_s > 0.0 && now >= next_watchdog) {
      // Only a loop that is still moving is healthy.
      const std::uint64_t beat = runner.heartbeat();
      if (beat != last_heartbeat) notify.watchdog();
      last_heartbeat = beat;
      next_watchdog = now + std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(watchdog_s / 2));
    }
    if (config.output.status_interval_s > 0.0 && now >= next_status) {
      const LoopCounters c = runner.counters();
      const LoopStatus st = runner.status();
      const LatencyHistogram::Summary l = runner.latency();
      char text[400];
      std::snprintf(text, sizeof text,
                    "status: %" PRIu64 " samples, casing %.3f C (setpoint %.2f), TEC %.3f A, flags %s, "
                    "overruns %" PRIu64 ", missed conversions %" PRIu64 ", late reads %" PRIu64
                    ", spurious edges %" PRIu64 ", DRDY timeouts %" PRIu64
                    ", latency us min %.0f avg %.1f p99 %s%.0f max %.0f",
                    c.samples, st.casing_c, st.setpoint_c, st.tec_a, flag_names(st.flags).c_str(), c.overruns, c.missed_conversions,
                    c.late_reads, c.spurious_edges, c.adc_timeouts, us(l.min_s), us(l.avg_s), l.p99_over ? ">" : "",
                    us(l.p99_s), us(l.max_s));
      GYROTC_LOG_INFO("%s", text);
      if (options.selfcal_experiment) log_sweep_progress(sweep, st.casing_c);
      next_status += std::chrono::duration_cast<clock::duration>(
          std::chrono::duration<double>(config.output.status_interval_s));
    }
  }
  const double elapsed_s = std::chrono::duration<double>(clock::now() - started).count();
  notify.stopping();
  runner.stop();  // joins, drains the outputs, TEC 0 A, OPA548 disabled, rate DAC mid-scale
  outputs.flush();

  const LoopCounters c = runner.counters();
  const LatencyHistogram::Summary l = runner.latency();
  const bool wrong_way = options.tune_experiment && experiment.phase() == tune::ExperimentPhase::wrong_way;
  const char* stopped_by = stop_signal != 0 ? (stop_signal == SIGINT ? "SIGINT" : "SIGTERM")
                           : wrong_way       ? "experiment stopped (TEC wired the wrong way round)"
                           : controller.program_finished() ? "experiment finished"
                                                           : "duration reached";
  GYROTC_LOG_NOTICE("%s after %.1f s: TEC at 0 A, OPA548 disabled (safe-off)", stopped_by, elapsed_s);
  publisher.stopped(stopped_by, c, l, elapsed_s, unix_now_s());
  GYROTC_LOG_NOTICE("summary: %" PRIu64 " samples, %" PRIu64 " PID ticks, %" PRIu64 " readings, overruns %" PRIu64
                    ", missed conversions %" PRIu64 ", late reads %" PRIu64 ", spurious edges %" PRIu64
                    ", DRDY timeouts %" PRIu64 ", rows dropped %" PRIu64
                    "; latency us min %.1f avg %.1f p50 %.0f p99 %s%.0f max %.1f",
                    c.samples, c.pid_ticks, c.readings, c.overruns, c.missed_conversions, c.late_reads,
                    c.spurious_edges, c.adc_timeouts, c.rows_dropped, us(l.min_s), us(l.avg_s), us(l.p50_s),
                    l.p99_over ? ">" : "", us(l.p99_s), us(l.max_s));
  if (instance.sim_board) {
    const hal::SimBoard& sim = *instance.sim_board;
    GYROTC_LOG_NOTICE("simulated ADS1251: %" PRIu64 " transfers, %" PRIu64 " corrupted (late or early); samples "
                      "accepted %" PRIu64 ", of them corrupted %" PRIu64,
                      sim.adc_chip().counters().reads, sim.adc_chip().counters().corrupted_reads,
                      sim.accepted_samples(), sim.accepted_corrupted_samples());
  }
  const std::uint64_t lines_dropped = outputs.lines_dropped();
  for (const std::string& error : outputs.first_errors()) GYROTC_LOG_WARNING("output %s", error.c_str());

  if (!options.summary_json.empty()) {
    nlohmann::json j;
    j["config"] = config.source;
    j["hal"] = config.board.hal == HalKind::sim ? "sim" : "linux";
    j["elapsed_s"] = elapsed_s;
    j["stopped_by"] = std::string(stopped_by) == "duration reached" ? "duration" : stopped_by;
    j["realtime"] = runner.is_realtime();
    j["memory_locked"] = runner.memory_locked();
    j["samples"] = c.samples;
    j["overruns"] = c.overruns;
    j["missed_drdy"] = c.missed_drdy;
    j["adc_timeouts"] = c.adc_timeouts;
    j["missed_conversions"] = c.missed_conversions;
    j["late_reads"] = c.late_reads;
    j["spurious_edges"] = c.spurious_edges;
    j["pid_ticks"] = c.pid_ticks;
    j["readings"] = c.readings;
    j["rows_dropped"] = c.rows_dropped;
    j["lines_dropped"] = lines_dropped;
    j["flags"] = controller.flags();
    j["latency_us"] = latency_us_json(l);
    if (instance.sim_board) {
      // What the simulated hardware shows after the safe-off.
      const hal::SimBoard& sim = *instance.sim_board;
      const auto& tec = config.board.devices.tec;
      j["final_state"] = {{"tec_current_a", (sim.tec_dac_chip().output_v() - 0.5 * config.board.devices.tec_dac.vref_v) *
                                                tec.gain_a_per_v},
                          {"opa548_enabled", sim.opa548_chip().output_enabled()}};
      // What the simulated ADS1251 saw, against what the driver reported.
      const hal::SimAds1251::Counters adc = sim.adc_chip().counters();
      j["sim_adc"] = {{"conversions", adc.conversions},
                      {"transfers", adc.reads},
                      {"corrupted_transfers", adc.corrupted_reads},
                      {"dropped_events", adc.dropped_events},
                      {"accepted_samples", sim.accepted_samples()},
                      {"accepted_corrupted_samples", sim.accepted_corrupted_samples()}};
    }
    std::ofstream out(options.summary_json);
    out << j.dump(2) << '\n';
    if (!out) throw RuntimeFailure("cannot write the summary to '" + options.summary_json + "'");
  }
  if (wrong_way) {
    throw RuntimeFailure(tune::wrong_way_message(experiment.plan()));
  }
  return stopped_by;
}

}  // namespace gyrotc::app
