// `gyrotc calibrate`: the zero-bias calibration without a chamber (issue
// 30). The unit's own TEC sweeps the casing below and above the ambient
// (calibrate/sweep_experiment.hpp), then the record is fitted as `gyrotc fit
// --method auto` fits it, and refused when its range does not cover what the
// unit sees in service.
#include <CLI/CLI.hpp>

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <system_error>

#include <nlohmann/json.hpp>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/cli/cli_main.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/session.hpp"
#include "gyrotc/app/daemon/status_reader.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/support/output_path.hpp"
#include "gyrotc/app/workflows/self_calibration.hpp"

namespace gyrotc::app {
namespace {

struct CalibrateOptions {
  std::string config;
  std::string data;
  std::string out;
  std::string plot;
  std::string record;
  std::optional<double> die_lag_s;  // default: as the sweep's up/down passes measure it
  bool install = false;
  bool allow_non_rt = false;
  bool json = false;
};

// The upward and downward passes' split, for the report: the die's lag and
// any hysteresis (docs/SELFCAL.md).
nlohmann::json up_down_json(const calibrate::UpDownDifference& d) {
  nlohmann::json bins = nlohmann::json::array();
  for (const calibrate::UpDownBin& b : d.bins) {
    bins.push_back({{"temp_c", b.temp_c}, {"up_mv", b.up_mv}, {"down_mv", b.down_mv}});
  }
  const calibrate::LagAndHysteresis& s = d.separation;
  nlohmann::json separation = {{"separated", s.separated}};
  if (s.separated) {
    separation["die_lag_s"] = s.die_lag_s;
    separation["die_lag_s_std"] = s.die_lag_s_std;
    separation["split_mv"] = s.split_mv;
    separation["split_mv_std"] = s.split_mv_std;
  } else {
    separation["why_not"] = s.why_not;
  }
  return {{"max_abs_mv", d.max_abs_mv}, {"max_at_c", d.max_at_c}, {"mean_abs_mv", d.mean_abs_mv},
          {"separation", separation}, {"bins", bins}};
}

// The lag the whole record shows (calibrate/die_lag_from_record.hpp).
nlohmann::json record_lag_json(const calibrate::RecordLag& r) {
  nlohmann::json j = {{"found", r.found}};
  if (std::isfinite(r.die_lag_s)) {
    j["die_lag_s"] = r.die_lag_s;
    j["die_lag_s_std"] = r.die_lag_s_std;
    j["split_mv"] = r.split_mv;
  }
  if (!r.found) j["why_not"] = r.why_not;
  return j;
}

// The die's lag the record is binned with: the one asked for, else the one
// the passes' split measures, else the one the whole record shows where the
// passes cannot (a nearly straight curve), else none (the sensor's reading).
enum class LagFrom : std::uint8_t { given, measured, record, none };

const char* to_string(LagFrom from) noexcept {
  switch (from) {
    case LagFrom::given: return "given";
    case LagFrom::measured: return "measured";
    case LagFrom::record: return "record";
    case LagFrom::none: return "none";
  }
  return "?";
}

struct DieLag {
  double lag_s = 0.0;
  double lag_s_std = 0.0;  // where measured
  LagFrom from = LagFrom::none;
};

DieLag die_lag_for(const CalibrateOptions& o, const SweepLags& lags) {
  if (o.die_lag_s) return {*o.die_lag_s, 0.0, LagFrom::given};
  const calibrate::LagAndHysteresis& s = lags.passes.separation;
  if (s.separated) return {std::max(0.0, s.die_lag_s), s.die_lag_s_std, LagFrom::measured};
  if (lags.record.found) return {lags.record.die_lag_s, lags.record.die_lag_s_std, LagFrom::record};
  return {};
}

void print_die_lag(const DieLag& lag) {
  if (lag.from == LagFrom::measured) {
    std::printf("die: binned by the die's temperature, the casing sensor through the %.1f s lag the up/down passes "
                "measure (below; --die-lag-s to set it)\n",
                lag.lag_s);
  } else if (lag.from == LagFrom::record) {
    std::printf("die: binned by the die's temperature, the casing sensor through the %.1f s lag the whole record "
                "shows where the casing starts, stops and turns (the passes cannot measure it: below; --die-lag-s to "
                "set it)\n",
                lag.lag_s);
  } else if (lag.from == LagFrom::given && lag.lag_s > 0.0) {
    std::printf("die: binned by the die's temperature, the casing sensor through a %.1f s lag (--die-lag-s)\n",
                lag.lag_s);
  } else if (lag.from == LagFrom::given) {
    std::printf("die: binned by the casing sensor's reading (--die-lag-s 0)\n");
  } else {
    std::printf("die: binned by the casing sensor's reading: neither the up/down passes (below) nor the whole "
                "record measure the die's lag (--die-lag-s to give it)\n");
  }
}

// The record's range against the service range, then the fit.
void fit_and_check(const std::string& record, const CalibrateOptions& o) {
  const SweepLags lags = read_sweep_lags(record);
  const calibrate::UpDownDifference& split = lags.passes;
  const DieLag lag = die_lag_for(o, lags);
  const RecordRange range = read_record_range(record, lag.lag_s);
  const std::string gap = service_range_gap(range);
  if (!gap.empty()) {
    throw InputError(record + ": cannot calibrate for service: " + gap +
                     "; run the sweep at a lower ambient, or calibrate in a chamber (gyrotc fit)");
  }
  if (!o.json) print_die_lag(lag);
  fit_record_auto(record, lag.lag_s, lag.lag_s_std, o.out, o.plot, o.json,
                  {{"up_down", up_down_json(split)},
                   {"record_lag", record_lag_json(lags.record)},
                   {"die_lag_from", to_string(lag.from)}});
  if (o.json) return;
  if (split.bins.empty()) {
    std::printf("up/down: no temperature crossed both ways (not a self-calibration sweep?)\n");
    return;
  }
  const double scale = fit::Compensator::kSeedScaleMvPerDps;
  std::printf("up/down: the passes differ by %.3f mV (%.4f deg/s) on average over %zu bins, at most %.3f mV "
              "(%.4f deg/s) at %.1f C: the die's lag and any hysteresis, what a unit warming or cooling through "
              "these temperatures at the sweep's rate sees about the fitted mean\n",
              split.mean_abs_mv, split.mean_abs_mv / scale, split.bins.size(), split.max_abs_mv,
              split.max_abs_mv / scale, split.max_at_c);
  const calibrate::LagAndHysteresis& s = split.separation;
  if (!s.separated) {
    std::printf("up/down: the die's lag and a hysteresis not told apart: %s\n", s.why_not.c_str());
    const calibrate::RecordLag& r = lags.record;
    if (r.found) {
      std::printf("record: the die lags the casing sensor by %.1f +/- %.1f s, as the gyro follows where the casing "
                  "starts, stops and turns (a split of %.3f mV beside it)\n",
                  r.die_lag_s, r.die_lag_s_std, r.split_mv);
    } else {
      std::printf("record: no die's lag found where the casing starts, stops and turns: %s\n", r.why_not.c_str());
    }
    return;
  }
  std::printf("up/down: the die lags the casing sensor by %.1f +/- %.1f s; a split of %.3f +/- %.3f mV (%.4f deg/s) "
              "does not follow the curve's slope: a hysteresis, or a response to the rate of change itself\n",
              s.die_lag_s, s.die_lag_s_std, s.split_mv, s.split_mv_std, s.split_mv / scale);
}

// The pid of the daemon that runs on this configuration's board, from its
// status file (written once a second while it runs), or 0.
int running_daemon_pid(const DaemonConfig& config) {
  if (config.output.status_file.empty()) return 0;
  try {
    const DaemonStatusRead read = read_daemon_status(config.output.status_file, 5.0);
    return read.problem.empty() ? read.pid : 0;
  } catch (const RuntimeFailure&) {
    return 0;  // no status file: no daemon
  }
}

// Atomically in place of the configuration's calibration file; a daemon
// running on it reloads (SIGHUP, as `systemctl reload gyrotc`).
void install(const std::string& calibration, const DaemonConfig& config) {
  if (config.calibration_file.empty()) {
    throw InputError(config.source + ": [calibration] file is not set: nowhere to install " + calibration);
  }
  const std::filesystem::path target(config.calibration_file);
  const std::filesystem::path staged = target.string() + ".new";
  std::error_code ec;
  std::filesystem::copy_file(calibration, staged, std::filesystem::copy_options::overwrite_existing, ec);
  if (!ec) std::filesystem::rename(staged, target, ec);
  if (ec) throw RuntimeFailure(target.string() + ": cannot install the calibration: " + ec.message());
  std::printf("installed %s as %s\n", calibration.c_str(), target.c_str());
  const int pid = running_daemon_pid(config);
  if (pid == 0) {
    std::printf("no gyrotc daemon runs on %s: it takes the calibration when it starts\n", config.source.c_str());
    return;
  }
  if (::kill(pid, SIGHUP) != 0) {
    throw RuntimeFailure("installed, but the running daemon (pid " + std::to_string(pid) +
                         ") could not be told to reload: `systemctl reload gyrotc`");
  }
  std::printf("the running daemon (pid %d) reloads it (SIGHUP; its log says whether it took it)\n", pid);
}

void run(const CalibrateOptions& o) {
  prepare_output_file(o.out, "--out");
  if (!o.plot.empty()) prepare_output_file(o.plot, "--plot");
  if (!o.data.empty()) {
    if (o.install && o.config.empty()) {
      throw InputError("--install: needs --config, the board whose calibration file it replaces");
    }
    if (!o.record.empty()) throw InputError("--record: not with --data (no sweep is run)");
    if (o.allow_non_rt) throw InputError("--allow-non-rt: not with --data (no sweep is run)");
    fit_and_check(o.data, o);
    if (o.install) install(o.out, load_daemon_config(o.config));
    return;
  }
  const DaemonConfig config = load_daemon_config(o.config);
  SessionOptions session;
  session.config_path = o.config;
  session.record_csv = o.record.empty() ? o.out + ".record.csv" : o.record;
  session.stream = false;
  session.allow_non_rt = o.allow_non_rt;
  session.selfcal_experiment = true;
  prepare_output_file(session.record_csv, "--record");
  const std::string stopped_by = run_session(session);
  if (stopped_by != "experiment finished") {
    throw RuntimeFailure("the sweep stopped (" + stopped_by + ") before it finished: nothing fitted; its record is " +
                         session.record_csv);
  }
  fit_and_check(session.record_csv, o);
  if (o.install) install(o.out, config);
}

}  // namespace

void add_calibrate_command(CLI::App& app) {
  auto o = std::make_shared<CalibrateOptions>();
  CLI::App* cmd = app.add_subcommand(
      "calibrate",
      "Calibrate the zero-bias model without a chamber: with the gyro at rest, the unit's own TEC sweeps the\n"
      "casing from 12 C below the ambient to 12 C above the setpoint (never within 5 C of [failsafe]\n"
      "over_temp_c; an end the stage cannot reach at this ambient is where it stalls) and back, at 0.6 C/min,\n"
      "every temperature crossed once each way, each end held until the gyro's output settles (at most 4 h\n"
      "at 20 C). The split between the two passes measures the die's lag behind the casing sensor (on a\n"
      "nearly straight curve, the whole record's starts, stops and turns do); the record is binned by the\n"
      "die's temperature so estimated and fitted as `gyrotc fit --method auto` fits (each 1 C bin held out\n"
      "with the bins within 2 C of it, which share the gyro's bias wander), and the calibration file\n"
      "written with the lag, at which the unit then compensates. Refused when the range reached does not\n"
      "cover the ambient of the run up to the setpoint.\n"
      "On the board: --config (the service stopped: the run holds the board; every fail-safe on, safe-off on\n"
      "any signal). Without hardware: --data, the record of `gyrotc simulate --profile selfcal --out DIR`.");
  cmd->add_option("-c,--config", o->config,
                  "run the sweep on the board of this configuration (as `gyrotc record`); with --data, only the\n"
                  "board whose calibration --install replaces");
  cmd->add_option("--data", o->data,
                  "fit a sweep already recorded (`record --experiment selfcal`, or DIR/record.csv of `simulate\n"
                  "--profile selfcal`) instead of running one");
  cmd->add_option("--out", o->out, "the calibration file (TOML) to write")->required();
  cmd->add_option("--plot", o->plot, "the calibration report (SVG), as `gyrotc fit --plot`");
  cmd->add_option("--die-lag-s", o->die_lag_s,
                  "the die's lag behind the casing sensor, s, to bin the record by the die's temperature with\n"
                  "(default: as the sweep's up/down passes measure it; where they cannot, a nearly straight curve,\n"
                  "as the whole record shows it; where neither does, the sensor's reading; 0: the sensor's reading).\n"
                  "The calibration file keeps the lag (die_lag_s): the unit compensates at the die's temperature");
  cmd->add_option("--record", o->record, "--config: where the sweep's record goes (default: OUT.record.csv)");
  cmd->add_flag("--install", o->install,
                "put the calibration in place of --config's [calibration] file; a daemon running on that\n"
                "configuration reloads it (SIGHUP)");
  cmd->add_flag("--allow-non-rt", o->allow_non_rt,
                "--config: run without SCHED_FIFO / locked memory when not permitted (a warning)");
  cmd->add_flag("--json", o->json, "print the fit's summary as one JSON object");
  cmd->callback([o] {
    if (o->die_lag_s && !(*o->die_lag_s >= 0.0 && std::isfinite(*o->die_lag_s))) {
      throw InputError("--die-lag-s: must be 0 or more seconds");
    }
    if (o->config.empty() && o->data.empty()) {
      throw CLI::ValidationError("calibrate: give --config FILE (run the sweep on the board) or --data RECORD "
                                 "(a recorded sweep)");
    }
    run(*o);
  });
}

}  // namespace gyrotc::app
