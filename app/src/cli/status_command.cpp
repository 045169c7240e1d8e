// `gyrotc status`: the running daemon's status file, for a person or a script.
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/status_reader.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

struct StatusOptions {
  std::string config_path = "/etc/gyrotc/gyrotc.toml";
  std::string status_file;  // "" = the configuration's [output] status_file
  bool json = false;
  double max_age_s = 5.0;
};

double number(const nlohmann::json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : std::nan("");
}

void print_for_a_person(const nlohmann::json& j) {
  const auto c = [&](const char* key) { return number(j, key); };
  std::printf("gyrotc (pid %d, %s board, up %s): %s\n", j.value("pid", 0),
              j.value("hal", "") == "sim" ? "the simulated" : "the", duration_text(c("uptime_s")).c_str(),
              j.value("summary", "").c_str());
  std::printf("  config       %s\n", j.value("config", "").c_str());
  if (std::isfinite(c("casing_c"))) {
    std::printf("  casing       %.3f C   setpoint %.2f C   error %+.3f C", c("casing_c"), c("setpoint_c"),
                c("error_c"));
    if (std::isfinite(c("held_error_c"))) std::printf(" (held within ±%.3f C)", c("held_error_c"));
    std::printf("\n");
  } else {
    std::printf("  casing       no valid reading yet   setpoint %.2f C\n", c("setpoint_c"));
  }
  if (std::isfinite(c("ambient_c"))) std::printf("  ambient      %.3f C\n", c("ambient_c"));
  std::printf("  TEC          %+.3f A commanded, limit %.2f A\n", c("tec_a"), c("tec_limit_a"));
  if (j.contains("estimate") && j["estimate"].is_object()) {
    const nlohmann::json& e = j["estimate"];
    std::printf("  model        holds %.3f C (estimated), ambient %.2f C, holding current %+.3f A\n", number(e, "held_c"),
                number(e, "ambient_c"), number(e, "holding_a"));
  }
  // A calibration of the die compensates at the die's estimate, not at the reading.
  if (std::isfinite(c("compensation_c")) && std::fabs(c("compensation_c") - c("casing_c")) > 5e-4) {
    std::printf("  compensated  at %.3f C (the die's estimate)\n", c("compensation_c"));
  }
  std::string flags;
  for (const auto& n : j.value("flag_names", nlohmann::json::array()))
    flags += (flags.empty() ? "" : ", ") + n.get<std::string>();
  std::printf("  flags        %s\n", flags.empty() ? "none" : flags.c_str());
  for (const auto& f : j.value("faults", nlohmann::json::array())) {
    const bool active = f.value("active", false);
    std::printf("  fault        %-18s raised %s%s\n", f.value("name", "").c_str(),
                clock_time(f.value("raised_unix_s", 0.0)).c_str(),
                active ? ", active" : (", cleared " + clock_time(f.value("cleared_unix_s", 0.0))).c_str());
  }
  const auto& cal = j.value("calibration", nlohmann::json::object());
  std::printf("  calibration  %s\n", cal.value("description", "").c_str());
  const auto& k = j.value("counters", nlohmann::json::object());
  const auto& l = j.value("latency_us", nlohmann::json::object());
  std::printf("  loop         %llu samples, %llu PID ticks; latency us p50 %.0f p99 %s%.0f max %.0f\n",
              k.value("samples", 0ULL), k.value("pid_ticks", 0ULL), l.value("p50", 0.0),
              l.value("p99_over", false) ? ">" : "", l.value("p99", 0.0), l.value("max", 0.0));
  std::printf(
      "  ADC          overruns %llu, missed conversions %llu, late reads %llu, spurious edges %llu, DRDY "
      "timeouts %llu\n",
      k.value("overruns", 0ULL), k.value("missed_conversions", 0ULL), k.value("late_reads", 0ULL),
      k.value("spurious_edges", 0ULL), k.value("adc_timeouts", 0ULL));
}

void show_status(const StatusOptions& o) {
  std::string path = o.status_file;
  if (path.empty()) {
    path = load_daemon_config(o.config_path).output.status_file;
    if (path.empty()) throw InputError(o.config_path + ": [output] status_file is \"\": this daemon keeps no status");
  }
  const DaemonStatusRead read = read_daemon_status(path, o.max_age_s);
  nlohmann::json j = read.status;
  const std::string& problem = read.problem;
  if (o.json) {
    j["status_file"] = path;
    j["age_s"] = read.age_s;
    j["problem"] = problem.empty() ? nlohmann::json(nullptr) : nlohmann::json(problem);
    std::printf("%s\n", j.dump(2).c_str());
  } else if (problem.empty()) {
    print_for_a_person(j);
  }
  if (!problem.empty()) throw RuntimeFailure(problem);
}

}  // namespace

void add_status_command(CLI::App& app) {
  auto o = std::make_shared<StatusOptions>();
  CLI::App* cmd = app.add_subcommand(
      "status",
      "How the running daemon is doing: its state in words (warming, holding, saturated, fault and which, ...),\n"
      "the casing and ambient temperatures, setpoint and error, the TEC current and its limit, the calibration\n"
      "in use, faults with their times, loop latency and counters. Read from the status file the daemon writes\n"
      "once a second ([output] status_file, default /run/gyrotc/status.json); no device is touched.\n"
      "Exit 0 while a daemon runs; exit 1, saying why, when none does (stopped, crashed) or its status is\n"
      "older than --max-age (hung). --json prints the file's fields for a script (docs/GUIDE.md), also then.");
  cmd->add_option("--config", o->config_path, "the daemon's configuration file (its [output] status_file)")
      ->capture_default_str();
  cmd->add_option("--status-file", o->status_file, "read this status file instead of the configuration's");
  cmd->add_flag("--json", o->json, "print the status as JSON (adds status_file, age_s and problem)");
  cmd->add_option("--max-age", o->max_age_s, "a status older than this many seconds is stale")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->callback([o] { show_status(*o); });
}

}  // namespace gyrotc::app
