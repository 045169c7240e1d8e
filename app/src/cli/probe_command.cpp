// `gyrotc probe`: read every configured device once and say what was found.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "gyrotc/algorithms/text/printf_string.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/formats/board_config.hpp"
#include "gyrotc/app/formats/calibration_in_use.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/hal/linux/gpio_persistence.hpp"

namespace gyrotc::app {

namespace {

struct DeviceResult {
  std::string device;
  std::string status;  // "ok", "warning", "error", "skipped"
  std::string detail;
  // --json: what the detail says, as numbers (units in the names) and words
  // a script can use; empty when there is nothing to measure.
  nlohmann::ordered_json values = nlohmann::ordered_json::object();
};

DeviceResult probe_sensor(const char* device, hal::TemperatureSensor& sensor) {
  const hal::TemperatureReading reading = sensor.read();
  const std::string name(sensor.name());
  if (reading.valid) {
    return {device,
            "ok",
            text::printf_string("%.4f C (%s)", reading.temp_c, name.c_str()),
            {{"temp_c", reading.temp_c}, {"sensor", name}}};
  }
  return {device, "error", name + ": " + std::string(hal::to_string(reading.fault))};
}

// One sample for its value, then a short run of reads for the driver's
// counters (conversions dropped as late reads, DRDY line noise, conversions
// missed); probe runs without real-time priority, so some misses are normal.
DeviceResult probe_adc(hal::Board& board, double sample_period_s, double timeout_s) {
  const hal::Result<hal::AdcSample> sample = board.adc.read(timeout_s);
  if (!sample) return {"adc", "error", std::string(sample.error().message())};
  const int burst = static_cast<int>(std::clamp(0.2 / sample_period_s, 1.0, 200.0));
  int read = 1;
  for (int i = 1; i < burst; ++i) {
    if (board.adc.read(timeout_s)) ++read;
  }
  const hal::AdcReadStats stats = board.adc.stats();
  return {"adc",
          "ok",
          text::printf_string(
              "code %d = %.4f mV%s; %d of %d reads: late reads %llu, spurious edges %llu, missed conversions %llu",
              sample->code, sample->gyro_mv, sample->clipped ? " (clipped at full scale)" : "", read, burst,
              static_cast<unsigned long long>(stats.late_reads), static_cast<unsigned long long>(stats.spurious_edges),
              static_cast<unsigned long long>(stats.missed_conversions)),
          {{"code", sample->code},
           {"gyro_mv", sample->gyro_mv},
           {"clipped", sample->clipped},
           {"reads", read},
           {"reads_tried", burst},
           {"late_reads", stats.late_reads},
           {"spurious_edges", stats.spurious_edges},
           {"missed_conversions", stats.missed_conversions}}};
}

// E/S shows a thermal shutdown only while the OPA548 is enabled (disabled,
// the board holds it low), and only through a sense line: with one, the
// OPA548 is enabled for kThermalLookS with the DAC at 0 A, then disabled.
constexpr double kThermalLookS = 0.01;

DeviceResult probe_opa548(hal::Board& board) {
  if (!board.tec.senses_thermal()) {
    return {"opa548", "warning",
            "disabled; thermal state unknown: no E/S sense line ([devices.opa548] es_sense), the E/S GPIO only "
            "drives the pin, so a thermal shutdown cannot be seen"};
  }
  hal::Result<hal::ThermalStatus> status = hal::ThermalStatus::unknown;
  if (const hal::Status on = board.tec.enable(true); !on) {
    status = on.error();
  } else {
    board.clock.sleep_until(board.clock.now_s() + kThermalLookS);
    status = board.tec.thermal_status();
  }
  const hal::Status off = board.tec.safe_off();
  if (!off) return {"opa548", "error", "could not disable it again: " + std::string(off.error().message())};
  if (!status) return {"opa548", "error", std::string(status.error().message())};
  if (*status == hal::ThermalStatus::shutdown) {
    return {"opa548", "error", "thermal shutdown: E/S read low while enabled at 0 A; disabled again"};
  }
  return {"opa548",
          "ok",
          text::printf_string("thermal flag %s (enabled %.0f ms at 0 A to read E/S), disabled again",
                              std::string(hal::to_string(*status)).c_str(), kThermalLookS * 1e3),
          {{"thermal", std::string(hal::to_string(*status))}, {"enabled_for_s", kThermalLookS}}};
}

// Reads each device of a built board once. The outputs stay safe: the TEC
// at 0 A with the OPA548 disabled, the rate DAC where the board put it.
std::vector<DeviceResult> probe_board(hal::Board board, double sample_period_s, double adc_timeout_s) {
  std::vector<DeviceResult> results;
  results.push_back(probe_adc(board, sample_period_s, adc_timeout_s));
  results.push_back(probe_sensor("casing_sensor", board.casing_sensor));
  if (board.ambient_sensor != nullptr) results.push_back(probe_sensor("ambient_sensor", *board.ambient_sensor));
  results.push_back({"rate_dac", "ok", "written at mid-scale (the AD5060 has no read-back)"});
  if (const hal::Status off = board.tec.safe_off(); off) {
    results.push_back({"tec_dac", "ok", "at 0 A (mid-scale)"});
    results.push_back(probe_opa548(board));
  } else {
    results.push_back({"tec_dac", "error", std::string(off.error().message())});
    results.push_back({"opa548", "skipped", "not enabled to read E/S: the TEC DAC is not known to be at 0 A"});
  }
  return results;
}

toml::table read_toml(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw InputError(path + ": no such configuration file");
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw InputError(path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
}

// The calibration the configuration names, as the daemon would load it.
DeviceResult probe_calibration(const std::string& file) {
  try {
    const CalibrationInUse c = load_calibration_in_use(file);
    nlohmann::ordered_json values{{"file", c.file}, {"model", c.model.kind_name()}, {"sha256", c.sha256}};
    if (c.model.kind() != fit::BiasModel::Kind::paper_reference) {
      values["range_c"] = {c.model.t_min_c(), c.model.t_max_c()};
    }
    values["scale_mv_per_dps"] = c.scale_mv_per_dps;
    values["die_lag_s"] = c.die_lag_s;
    return {"calibration", "ok", describe(c), values};
  } catch (const InputError& e) {
    return {"calibration", "error", e.what()};
  }
}

void run_probe(const std::string& config_path, bool json) {
  read_toml(config_path);  // a missing or unparsable file: one clear line
  const DaemonConfig daemon = load_daemon_config(config_path);
  const BoardConfig& config = daemon.board;
  std::vector<DeviceResult> results;
  const double sample_period_s = hal::Ads1251::kClocksPerSample / config.devices.adc.fclk_hz;
  const double adc_timeout_s = 10.0 * sample_period_s + 0.1;
  if (config.hal == HalKind::sim) {
    BoardInstance instance = make_board(config, SimTiming::lockstep);
    results = probe_board(instance.board(), sample_period_s, adc_timeout_s);
  } else {
    hal::LinuxBoard::Opened opened = hal::LinuxBoard::open(config.devices);
    if (opened.board) {
      results = probe_board(opened.board->board(), sample_period_s, adc_timeout_s);
    } else {
      std::vector<std::string> devices{"adc", "casing_sensor"};
      if (config.devices.ambient_sensor) devices.push_back("ambient_sensor");
      devices.insert(devices.end(), {"rate_dac", "tec_dac", "opa548"});
      for (const std::string& device : devices) {
        const auto failure = std::find_if(opened.failures.begin(), opened.failures.end(),
                                          [&](const hal::DeviceFailure& f) { return f.device == device; });
        if (failure != opened.failures.end()) {
          results.push_back({device, "error", failure->message});
        } else {
          results.push_back({device, "skipped", "opened, not read: other devices failed"});
        }
      }
    }
    if (hal::gpio_outputs_persist().value_or(false)) {
      results.push_back({"gpio_release", "warning",
                         std::string("released GPIO outputs keep driving (") + hal::kPersistGpioOutputsPath +
                             " = Y): a gyrotc dying outside systemd leaves E/S as it was; set dtparam=strict_gpiod"});
    }
  }

  results.push_back(probe_calibration(daemon.calibration_file));

  bool all_ok = true;
  for (const DeviceResult& r : results) all_ok = all_ok && (r.status == "ok" || r.status == "warning");
  const char* hal_name = config.hal == HalKind::sim ? "sim" : "linux";
  if (json) {
    nlohmann::ordered_json out{{"hal", hal_name}, {"ok", all_ok}, {"devices", nlohmann::ordered_json::array()}};
    for (const DeviceResult& r : results) {
      nlohmann::ordered_json d{{"device", r.device}, {"status", r.status}, {"detail", r.detail}};
      if (!r.values.empty()) d["values"] = r.values;
      out["devices"].push_back(d);
    }
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf("board: hal = \"%s\" (%s)\n", hal_name, config_path.c_str());
    for (const DeviceResult& r : results) {
      const char* status = r.status == "ok"        ? "OK"
                           : r.status == "warning" ? "WARNING"
                           : r.status == "error"   ? "ERROR"
                                                   : "SKIPPED";
      std::printf("%-15s %-7s %s\n", r.device.c_str(), status, r.detail.c_str());
    }
  }
  std::fflush(stdout);
  if (!all_ok) throw CommandExit(1);
}

}  // namespace

void add_probe_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "probe",
      "Read every configured device once and print what was found, one line per device: the temperature "
      "sensor(s), the ADC (one sample, then 0.2 s of reads for the driver's counts of late reads, spurious DRDY "
      "edges and missed conversions), the OPA548 thermal flag (with an es_sense line the OPA548 is enabled for "
      "10 ms with the TEC DAC at 0 A to read E/S; without one the state is unknown, a WARNING); then the "
      "calibration the configuration names (file, model, temperature range, SHA-256). DACs are left at 0 A / "
      "mid-scale and the OPA548 disabled. Exit status 1 if any device or the calibration failed (warnings do "
      "not count).");
  auto config_path = std::make_shared<std::string>("/etc/gyrotc/gyrotc.toml");
  auto json = std::make_shared<bool>(false);
  cmd->add_option("-c,--config", *config_path,
                  "configuration file (TOML) with hal = \"linux\" | \"sim\", [devices], [tec], [sim]; see "
                  "deploy/config/gyrotc-sim.toml")
      ->capture_default_str();
  cmd->add_flag("--json", *json, "print the result as JSON instead of a table");
  cmd->callback([config_path, json] { run_probe(*config_path, *json); });
}

}  // namespace gyrotc::app
