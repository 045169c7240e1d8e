// `gyrotc status`: a running daemon's status for a person or a script, and a
// clear non-zero answer when none runs, it died, or it hangs.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/daemon/daemon_status.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "run_command.hpp"
#include "test_paths.hpp"

using namespace gyrotc::app;
namespace fs = std::filesystem;

namespace {

double unix_now_s() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string status_path() {
  return (fs::path(gyrotc::test::scratch_dir()) / ("status_cmd_" + std::to_string(::getpid()) + ".json")).string();
}

// A status file as the daemon `pid` writes it, `age_s` ago.
std::string write_status(int pid, double age_s, bool running = true) {
  DaemonStatus s;
  s.pid = pid;
  s.hal = "sim";
  s.mode = "pid";
  s.running = running;
  s.stopped_by = "SIGTERM";
  s.casing_c = 55.01;
  s.ambient_c = std::nan("");
  s.setpoint_c = 55.0;
  s.held_error_c = 0.03;
  s.tec_a = 0.21;
  s.tec_limit_a = 1.0;
  s.written_unix_s = unix_now_s() - age_s;
  const std::string path = status_path();
  REQUIRE(write_file_atomically(path, status_json(s)).empty());
  return path;
}

std::string status(const std::vector<std::string>& args) {
  return gyrotc::test::run_command(add_status_command, "status", args);
}

std::string failure_of(const std::vector<std::string>& args) {
  try {
    status(args);
  } catch (const RuntimeFailure& e) {
    return e.what();
  }
  return "no error";
}

// A process id that is not running: a child that has exited and been reaped.
int gone_pid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int wstatus = 0;
  ::waitpid(child, &wstatus, 0);
  return child;
}

}  // namespace

TEST_CASE("status of a running daemon prints its state sentence and figures") {
  const std::string path = write_status(::getpid(), 0.0);
  const std::string out = status({"--status-file", path});
  CHECK_THAT(out, Catch::Contains("holding 55.00 °C ±0.03, TEC +0.21 A"));
  CHECK_THAT(out, Catch::Contains("TEC          +0.210 A commanded, limit 1.00 A"));
  fs::remove(path);
}

TEST_CASE("status --json gives a script the file's numbers and no problem") {
  const std::string path = write_status(::getpid(), 0.0);
  const nlohmann::json j = nlohmann::json::parse(status({"--status-file", path, "--json"}));
  CHECK(j["state"] == "holding");
  CHECK(j["casing_c"].get<double>() == 55.01);
  CHECK(j["problem"].is_null());
  CHECK(j["status_file"] == path);
  fs::remove(path);
}

TEST_CASE("status without a status file says no daemon runs and fails") {
  CHECK_THAT(failure_of({"--status-file", "/nonexistent-dir/status.json"}),
             Catch::Contains("no gyrotc daemon is running: no status file /nonexistent-dir/status.json"));
}

TEST_CASE("status after a clean stop says when and how it stopped, and fails") {
  const std::string path = write_status(::getpid(), 30.0, false);
  CHECK_THAT(failure_of({"--status-file", path}),
             Catch::Contains("the last one (pid") && Catch::Contains("(SIGTERM), TEC at 0 A"));
  fs::remove(path);
}

TEST_CASE("status of a daemon that died without stopping says so, and fails") {
  const std::string path = write_status(gone_pid(), 1.0);
  CHECK_THAT(failure_of({"--status-file", path}), Catch::Contains("has gone without stopping"));
  fs::remove(path);
}

TEST_CASE("status of a daemon that has not written for longer than --max-age is stale, and fails") {
  const std::string path = write_status(::getpid(), 20.0);
  CHECK_THAT(failure_of({"--status-file", path}), Catch::Contains("has not written its status for 20 s"));
  CHECK_NOTHROW(status({"--status-file", path, "--max-age", "60"}));
  fs::remove(path);
}

TEST_CASE("status --json of a stopped daemon fails as the text form does") {
  const std::string path = write_status(::getpid(), 30.0, false);
  CHECK_THROWS_AS(status({"--status-file", path, "--json"}), RuntimeFailure);
  fs::remove(path);
}

TEST_CASE("status refuses a file that is not a gyrotc status file") {
  const std::string path = status_path();
  std::ofstream(path) << "{\"format\": \"something-else\"}\n";
  CHECK_THAT(failure_of({"--status-file", path}), Catch::Contains("not a gyrotc status file"));
  std::ofstream(path) << "not json\n";
  CHECK_THAT(failure_of({"--status-file", path}), Catch::Contains("not a gyrotc status file"));
  fs::remove(path);
}

TEST_CASE("status reads the status file the configuration names") {
  const std::string path = write_status(::getpid(), 0.0);
  const fs::path config =
      fs::path(gyrotc::test::scratch_dir()) / ("status_cmd_" + std::to_string(::getpid()) + ".toml");
  std::ofstream(config) << "hal = \"sim\"\n[output]\nstatus_file = \"" << path << "\"\n";
  CHECK_THAT(status({"--config", config.string()}), Catch::Contains("holding 55.00"));
  fs::remove(config);
  fs::remove(path);
}
