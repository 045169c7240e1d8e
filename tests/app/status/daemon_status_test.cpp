// The daemon's status in words, as JSON and as Prometheus text: what
// `gyrotc status`, STATUS= and a monitoring system read.
#include "gyrotc/app/daemon/daemon_status.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc::app;

namespace {

DaemonStatus holding() {
  DaemonStatus s;
  s.pid = 1234;
  s.hal = "sim";
  s.config = "/etc/gyrotc/gyrotc.toml";
  s.mode = "pid";
  s.casing_c = 55.02;
  s.ambient_c = 16.0;
  s.setpoint_c = 55.0;
  s.held_error_c = 0.031;
  s.tec_a = 0.213;
  s.tec_limit_a = 1.0;
  s.calibration = "/etc/gyrotc/calibration.toml: spline, -40..80 C, sha256 1983c31e0859ad24";
  s.calibration_sha256 = "1983c31e0859ad2498c9666be4474cf2cf0aafab9e9810a8d3132a1dbea7f748";
  return s;
}

}  // namespace

TEST_CASE("the state is holding within the seed's 0.3 C band and warming or cooling outside it") {
  DaemonStatus s = holding();
  CHECK(state_word(s) == "holding");
  s.casing_c = 55.0 - 0.31;
  CHECK(state_word(s) == "warming");
  s.casing_c = 55.0 + 0.31;
  CHECK(state_word(s) == "cooling");
}

TEST_CASE("a fault flag outranks every operating state, and model_clamped alone is not a fault") {
  DaemonStatus s = holding();
  s.flags = kFlagModelClamped;
  CHECK(state_word(s) == "extrapolating");
  s.flags = kFlagTempStale | kFlagTecSaturated | kFlagTecOff;
  CHECK(state_word(s) == "fault");
  CHECK(status_sentence(s).rfind("fault temp_stale:", 0) == 0);
}

TEST_CASE("the PID at its limit is saturated, before any casing reading the daemon is starting") {
  DaemonStatus s = holding();
  s.casing_c = 30.0;
  s.flags = kFlagTecSaturated;
  CHECK(state_word(s) == "saturated");
  s.casing_c = std::nan("");
  CHECK(state_word(s) == "starting");
}

TEST_CASE("compensation only and the identification experiment say so, a stopped daemon says how") {
  DaemonStatus s = holding();
  s.mode = "tec_off";
  CHECK(state_word(s) == "tec_off");
  s.mode = "experiment";
  CHECK(state_word(s) == "experiment");
  s.running = false;
  s.stopped_by = "SIGTERM";
  CHECK(status_sentence(s) == "stopped (SIGTERM): TEC at 0 A, OPA548 disabled");
}

TEST_CASE("STATUS= is one short sentence with the setpoint, the error held and the current") {
  CHECK(status_sentence(holding()) == "holding 55.00 °C ±0.03, TEC +0.21 A");
}

TEST_CASE("the status file's JSON has numbers as numbers, flags decoded and no reading as null") {
  DaemonStatus s = holding();
  s.flags = kFlagTecSaturated | kFlagModelClamped;
  s.faults.push_back({"model_clamped", 1000.0, 0.0});
  s.faults.push_back({"temp_stale", 900.0, 950.0});
  s.counters.samples = 42;
  const nlohmann::json j = nlohmann::json::parse(status_json(s));
  CHECK(j["format"] == "gyrotc-status");
  CHECK(j["state"] == "saturated");
  CHECK(j["casing_c"].get<double>() == 55.02);
  CHECK(j["error_c"].get<double>() == Approx(0.02));
  CHECK(j["tec_a"].get<double>() == 0.213);
  CHECK(j["flag_names"] == nlohmann::json({"model_clamped", "tec_saturated"}));
  CHECK(j["faults"][0]["active"] == true);
  CHECK(j["faults"][1]["cleared_unix_s"].get<double>() == 950.0);
  CHECK(j["counters"]["samples"] == 42);
  CHECK(j["calibration"]["sha256"] == s.calibration_sha256);
  s.casing_c = std::nan("");
  s.ambient_c = std::nan("");
  const nlohmann::json k = nlohmann::json::parse(status_json(s));
  CHECK(k["casing_c"].is_null());
  CHECK(k["ambient_c"].is_null());
  CHECK(k["error_c"].is_null());
}

TEST_CASE("every Prometheus metric has a HELP and a TYPE line before its samples, units in its name") {
  const std::string text = prometheus_text(holding());
  std::istringstream in(text);
  std::set<std::string> declared;
  std::string line;
  int samples = 0;
  while (std::getline(in, line)) {
    if (line.rfind("# TYPE ", 0) == 0) {
      std::istringstream w(line.substr(7));
      std::string name;
      w >> name;
      declared.insert(name);
      continue;
    }
    if (line.rfind("# HELP ", 0) == 0) continue;
    const std::string name = line.substr(0, line.find_first_of("{ "));
    INFO(line);
    CHECK(declared.count(name) == 1);
    ++samples;
  }
  CHECK(samples > 20);
  CHECK(text.find("gyrotc_tec_current_amperes 0.213\n") != std::string::npos);
  CHECK(text.find("gyrotc_casing_temperature_celsius 55.02\n") != std::string::npos);
  CHECK(text.find("gyrotc_state{state=\"holding\"} 1\n") != std::string::npos);
  CHECK(text.find("gyrotc_state{state=\"warming\"} 0\n") != std::string::npos);
}

TEST_CASE("a Prometheus label value escapes quotes, backslashes and newlines") {
  DaemonStatus s = holding();
  s.calibration = "C:\\cal \"new\"\nline";
  CHECK(prometheus_text(s).find("description=\"C:\\\\cal \\\"new\\\"\\nline\"") != std::string::npos);
}

TEST_CASE("a status file is replaced whole and readable by every user") {
  const std::filesystem::path p =
      std::filesystem::path(gyrotc::test::scratch_dir()) / ("status_" + std::to_string(::getpid()) + ".json");
  const mode_t old = ::umask(0077);
  REQUIRE(write_file_atomically(p.string(), "first\n").empty());
  REQUIRE(write_file_atomically(p.string(), "second\n").empty());
  ::umask(old);
  std::ifstream in(p);
  CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == "second\n");
  struct stat st {};
  REQUIRE(::stat(p.c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0644);
  std::size_t leftovers = 0;
  for (const auto& e : std::filesystem::directory_iterator(p.parent_path())) {
    leftovers += e.path().filename().string().rfind(p.filename().string() + ".tmp", 0) == 0;
  }
  CHECK(leftovers == 0);
  std::filesystem::remove(p);
}

TEST_CASE("a status file that cannot be written is an answer naming it, not an exception") {
  const std::string error = write_file_atomically("/nonexistent-dir/status.json", "x");
  CHECK(error.find("/nonexistent-dir/status.json") != std::string::npos);
}

TEST_CASE("the model-based loop's estimates are in the JSON and the Prometheus text, absent with the PID") {
  DaemonStatus pid = holding();
  pid.compensation_c = 55.02;
  const nlohmann::json j = nlohmann::json::parse(status_json(pid));
  CHECK(j["estimate"].is_null());
  CHECK(j["compensation_c"].get<double>() == 55.02);
  const std::string pid_text = prometheus_text(pid);
  CHECK(pid_text.find("gyrotc_compensation_temperature_celsius 55.02\n") != std::string::npos);
  CHECK(pid_text.find("gyrotc_estimated_held_temperature_celsius") == std::string::npos);

  DaemonStatus observer = holding();
  observer.estimate = {.held_c = 55.004, .ambient_c = 16.2, .holding_a = 0.187};
  const nlohmann::json k = nlohmann::json::parse(status_json(observer));
  REQUIRE(k["estimate"].is_object());
  CHECK(k["estimate"]["held_c"].get<double>() == 55.004);
  CHECK(k["estimate"]["ambient_c"].get<double>() == 16.2);
  CHECK(k["estimate"]["holding_a"].get<double>() == 0.187);
  CHECK(k["compensation_c"].is_null());
  const std::string text = prometheus_text(observer);
  CHECK(text.find("gyrotc_estimated_held_temperature_celsius 55.004\n") != std::string::npos);
  CHECK(text.find("gyrotc_estimated_ambient_temperature_celsius 16.2\n") != std::string::npos);
  CHECK(text.find("gyrotc_holding_current_amperes 0.187\n") != std::string::npos);
}

TEST_CASE("compensated outside the calibration's range the state is extrapolating, naming the range") {
  DaemonStatus s = holding();
  s.calibration_lo_c = 8.0;
  s.calibration_hi_c = 67.0;
  s.compensation_c = 5.31;
  s.casing_c = 5.4;
  s.flags = kFlagModelClamped;
  CHECK(state_word(s) == "extrapolating");
  CHECK(status_sentence(s) ==
        "extrapolating: compensated at 5.31 °C, outside the calibration's 8.0..67.0 °C; casing 5.40 °C, TEC +0.21 A");
  s.flags = 0;
  CHECK(state_word(s) == "warming");
}

TEST_CASE("the calibration's range and error bound are in the JSON and the Prometheus text, null without a bound") {
  DaemonStatus s = holding();
  s.calibration_lo_c = 8.0;
  s.calibration_hi_c = 67.0;
  s.calibration_bound_dps = 0.0091;
  const nlohmann::json j = nlohmann::json::parse(status_json(s));
  CHECK(j["calibration"]["bound_dps"].get<double>() == 0.0091);
  CHECK(j["calibration"]["range_c"][0].get<double>() == 8.0);
  CHECK(j["calibration"]["range_c"][1].get<double>() == 67.0);
  const std::string text = prometheus_text(s);
  CHECK(text.find("gyrotc_calibration_error_bound_dps 0.0091\n") != std::string::npos);
  CHECK(text.find("gyrotc_calibration_range_celsius{end=\"low\"} 8\n") != std::string::npos);
  CHECK(text.find("gyrotc_state{state=\"extrapolating\"} 0\n") != std::string::npos);

  DaemonStatus unbounded = holding();
  CHECK(nlohmann::json::parse(status_json(unbounded))["calibration"]["bound_dps"].is_null());
  CHECK(prometheus_text(unbounded).find("gyrotc_calibration_error_bound_dps") == std::string::npos);
}
