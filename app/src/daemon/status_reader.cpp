#include "gyrotc/app/daemon/status_reader.hpp"

#include <signal.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

bool process_exists(int pid) {
  // EPERM: it exists, under another user (the service's).
  return pid > 0 && (::kill(pid, 0) == 0 || errno == EPERM);
}

}  // namespace

DaemonStatusRead read_daemon_status(const std::string& path, double max_age_s) {
  std::ifstream in(path);
  if (!in) {
    throw RuntimeFailure("no gyrotc daemon is running: no status file " + path +
                         " (systemctl status gyrotc tells why the service is not running)");
  }
  std::stringstream text;
  text << in.rdbuf();
  DaemonStatusRead r;
  try {
    r.status = nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::exception&) {
    throw RuntimeFailure(path + ": not a gyrotc status file (no JSON)");
  }
  const nlohmann::json& j = r.status;
  if (!j.is_object() || j.value("format", "") != "gyrotc-status") {
    throw RuntimeFailure(path + ": not a gyrotc status file (format is not \"gyrotc-status\")");
  }
  r.pid = j.value("pid", 0);
  r.written_unix_s = j.contains("written_unix_s") && j["written_unix_s"].is_number()
                         ? j["written_unix_s"].get<double>()
                         : std::nan("");
  r.age_s = unix_now_s() - r.written_unix_s;
  if (!j.value("running", false)) {
    r.problem = "no gyrotc daemon is running: the last one (pid " + std::to_string(r.pid) + ") stopped at " +
                clock_time(r.written_unix_s) + " (" + j.value("stopped_by", std::string("?")) + "), TEC at 0 A";
  } else if (!process_exists(r.pid)) {
    r.problem = "no gyrotc daemon is running: pid " + std::to_string(r.pid) + " wrote " + path +
                " and has gone without stopping (a crash or a kill; last status " + clock_time(r.written_unix_s) + ")";
  } else if (!(r.age_s <= max_age_s)) {
    r.problem = "the gyrotc daemon (pid " + std::to_string(r.pid) + ") has not written its status for " +
                duration_text(r.age_s) + " (it writes once a second): its main thread is stuck";
  }
  return r;
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

}  // namespace gyrotc::app
