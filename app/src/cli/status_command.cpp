// `gyrotc status`: the running daemon's status file, for a person or a script.
#include <signal.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

struct StatusOptions {
  std::string config_path = "/etc/gyrotc/gyrotc.toml";
  std::string status_file;  // "" = the configuration's [output] status_file
  bool json = false;
  double max_age_s = 5.0;
};

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

bool process_exists(int pid) {
  // EPERM: it exists, under another user (the service's).
  return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM);
}

std::string clock_time(double unix_s) {
  const std::time_t t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  ::localtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S", &tm);
  return text;
}

std::string duration_text(double s) {
  char text[48];
  const long total = static_cast<long>(s);
  if (total < 120) {
    std::snprintf(text, sizeof text, "%ld s", total);
  } else if (total < 7200) {
    std::snprintf(text, sizeof text, "%ld min %02ld s", total / 60, total % 60);
  } else {
    std::snprintf(text, sizeof text, "%ld h %02ld min", total / 3600, (total % 3600) / 60);
  }
  return text;
}

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
  std::ifstream in(path);
  if (!in) {
    throw RuntimeFailure("no gyrotc daemon is running: no status file " + path +
                         " (systemctl status gyrotc tells why the service is not running)");
  }
  std::stringstream text;
  text << in.rdbuf();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::exception&) {
    throw RuntimeFailure(path + ": not a gyrotc status file (no JSON)");
  }
  if (!j.is_object() || j.value("format", "") != "gyrotc-status") {
    throw RuntimeFailure(path + ": not a gyrotc status file (format is not \"gyrotc-status\")");
  }
  const int pid = j.value("pid", 0);
  const double written = number(j, "written_unix_s");
  std::string problem;
  if (!j.value("running", false)) {
    problem = "no gyrotc daemon is running: the last one (pid " + std::to_string(pid) + ") stopped at " +
              clock_time(written) + " (" + j.value("stopped_by", std::string("?")) + "), TEC at 0 A";
  } else if (!process_exists(pid)) {
    problem = "no gyrotc daemon is running: pid " + std::to_string(pid) + " wrote " + path +
              " and has gone without stopping (a crash or a kill; last status " + clock_time(written) + ")";
  } else if (!(unix_now_s() - written <= o.max_age_s)) {
    problem = "the gyrotc daemon (pid " + std::to_string(pid) + ") has not written its status for " +
              duration_text(unix_now_s() - written) + " (it writes once a second): its main thread is stuck";
  }
  if (o.json) {
    j["status_file"] = path;
    j["age_s"] = unix_now_s() - written;
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
