// `gyrotc probe`: read every configured device once and say what was found.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "gyrotc/app/board_config.hpp"
#include "gyrotc/app/calibration_in_use.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/errors.hpp"

namespace gyrotc::app {

namespace {

struct DeviceResult {
  std::string device;
  std::string status;  // "ok", "error", "skipped"
  std::string detail;
};

std::string format(const char* fmt, auto... args) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer, fmt, args...);
  return buffer;
}

DeviceResult probe_sensor(const char* device, hal::TemperatureSensor& sensor) {
  const hal::TemperatureReading reading = sensor.read();
  const std::string name(sensor.name());
  if (reading.valid) return {device, "ok", format("%.4f C (%s)", reading.temp_c, name.c_str())};
  return {device, "error", name + ": " + std::string(hal::to_string(reading.fault))};
}

// Reads each device of a built board once. The outputs stay safe: the TEC
// at 0 A with the OPA548 disabled, the rate DAC where the board put it.
std::vector<DeviceResult> probe_board(hal::Board board, double adc_timeout_s) {
  std::vector<DeviceResult> results;
  const hal::Result<hal::AdcSample> sample = board.adc.read(adc_timeout_s);
  if (sample) {
    results.push_back({"adc", "ok",
                       format("code %d = %.4f mV%s", sample->code, sample->gyro_mv,
                              sample->clipped ? " (clipped at full scale)" : "")});
  } else {
    results.push_back({"adc", "error", std::string(sample.error().message())});
  }
  results.push_back(probe_sensor("casing_sensor", board.casing_sensor));
  if (board.ambient_sensor != nullptr) results.push_back(probe_sensor("ambient_sensor", *board.ambient_sensor));
  results.push_back({"rate_dac", "ok", "written at mid-scale (the AD5060 has no read-back)"});
  if (const hal::Status off = board.tec.safe_off(); off) {
    results.push_back({"tec_dac", "ok", "at 0 A (mid-scale)"});
  } else {
    results.push_back({"tec_dac", "error", std::string(off.error().message())});
  }
  const hal::Result<bool> flag = board.tec.thermal_flag();
  if (!flag) {
    results.push_back({"opa548", "error", std::string(flag.error().message())});
  } else if (*flag) {
    results.push_back({"opa548", "error", "thermal shutdown flag set"});
  } else {
    results.push_back({"opa548", "ok", "disabled, thermal flag clear"});
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
    return {"calibration", "ok", describe(load_calibration_in_use(file))};
  } catch (const InputError& e) {
    return {"calibration", "error", e.what()};
  }
}

void run_probe(const std::string& config_path, bool json) {
  read_toml(config_path);  // a missing or unparsable file: one clear line
  const DaemonConfig daemon = load_daemon_config(config_path);
  const BoardConfig& config = daemon.board;
  std::vector<DeviceResult> results;
  const double adc_timeout_s = 10.0 * hal::Ads1251::kClocksPerSample / config.devices.adc.fclk_hz + 0.1;
  if (config.hal == HalKind::sim) {
    BoardInstance instance = make_board(config, SimTiming::lockstep);
    results = probe_board(instance.board(), adc_timeout_s);
  } else {
    hal::LinuxBoard::Opened opened = hal::LinuxBoard::open(config.devices);
    if (opened.board) {
      results = probe_board(opened.board->board(), adc_timeout_s);
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
  }

  results.push_back(probe_calibration(daemon.calibration_file));

  bool all_ok = true;
  for (const DeviceResult& r : results) all_ok = all_ok && r.status == "ok";
  const char* hal_name = config.hal == HalKind::sim ? "sim" : "linux";
  if (json) {
    nlohmann::json out{{"hal", hal_name}, {"ok", all_ok}, {"devices", nlohmann::json::array()}};
    for (const DeviceResult& r : results) {
      out["devices"].push_back({{"device", r.device}, {"status", r.status}, {"detail", r.detail}});
    }
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    std::printf("board: hal = \"%s\" (%s)\n", hal_name, config_path.c_str());
    for (const DeviceResult& r : results) {
      std::printf("%-15s %-7s %s\n", r.device.c_str(),
                  r.status == "ok" ? "OK" : r.status == "error" ? "ERROR" : "SKIPPED", r.detail.c_str());
    }
  }
  std::fflush(stdout);
  if (!all_ok) throw CommandExit(1);
}

}  // namespace

void add_probe_command(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "probe",
      "Read every configured device once (temperature sensor(s), one ADC sample, the OPA548 thermal flag) and "
      "print what was found, one line per device, then the calibration the configuration names (file, model, "
      "temperature range, SHA-256). DACs are left at 0 A / mid-scale and the OPA548 disabled. "
      "Exit status 1 if any device or the calibration failed.");
  auto config_path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  cmd->add_option("-c,--config", *config_path,
                  "configuration file (TOML) with hal = \"linux\" | \"sim\", [devices], [tec], [sim]; see "
                  "deploy/config/gyrotc-sim.toml")
      ->required();
  cmd->add_flag("--json", *json, "print the result as JSON instead of a table");
  cmd->callback([config_path, json] { run_probe(*config_path, *json); });
}

}  // namespace gyrotc::app
