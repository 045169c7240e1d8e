// `gyrotc calibrate` with gyrotc child processes on the simulated board in
// real time (issue 30): the self-calibration sweep runs through the real-time
// runner, reports its progress, and a signal in the middle of it ends in
// safe-off with nothing fitted and the exit status saying so; --install
// replaces the configuration's calibration and a running daemon reloads it.
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "gyrotc_catch.hpp"
#include "gyrotc_process.hpp"
#include "test_paths.hpp"

using namespace gyrotc::test;

// The test starts a `gyrotc` child with the runner's threads: native only
// under qemu (see link.cmake).
#if !defined(GYROTC_NO_GUEST_THREADS)

TEST_CASE("calibrate --config cools first through the real-time runner and a SIGTERM ends it in safe-off with "
          "nothing fitted and exit 1") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string out = dir + "/calibrate_board.toml";
  const std::string record = dir + "/calibrate_board.csv";
  const std::string err = dir + "/calibrate_board.err";
  std::remove(out.c_str());
  std::remove(record.c_str());
  const pid_t pid = spawn_gyrotc({"calibrate", "--config", gyrotc::test::sim_config_copy("calibrate_board_config"), "--out", out,
                                  "--record", record, "--allow-non-rt"},
                                 err);
  REQUIRE(pid > 0);
  REQUIRE(wait_for_text(err, "replaced by the self-calibration sweep"));
  // After its rest (0 A) the sweep cools: the casing ramps below the ambient.
  bool cooling = false;
  for (int i = 0; i < 900 && !cooling; ++i) {
    for (double a : record_tec_a(record)) cooling = cooling || a < -0.02;
    if (!cooling) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  CHECK(cooling);
  REQUIRE(wait_for_text(err, "self-calibration: down"));
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 1);
  const std::string text = read_text(err);
  CHECK(text.find("SIGTERM after") != std::string::npos);
  CHECK(text.find("TEC at 0 A, OPA548 disabled (safe-off)") != std::string::npos);
  CHECK(text.find("the sweep stopped (SIGTERM) before it finished: nothing fitted") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out));
}

TEST_CASE("calibrate --install puts the calibration in place of the configuration's and the running daemon reloads it") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/calibrate_install.toml";
  const std::string calibration = dir + "/calibrate_install_calibration.toml";
  const std::string status = dir + "/calibrate_install_status.json";
  const std::string err = dir + "/calibrate_install_daemon.err";
  std::ofstream(calibration) << read_text(gyrotc::test::data_file("calibration_table2.toml"));
  {
    std::string text = read_text(gyrotc::test::config_file("gyrotc-sim.toml"));
    const auto set = [&text](const std::string& from, const std::string& to) {
      text.replace(text.find(from), from.size(), to);
    };
    set("file = \"calibration.toml\"", "file = \"" + calibration + "\"");
    set("stream = \"stdout\"", "stream = \"none\"");
    set("status_file = \"/tmp/gyrotc-sim.status.json\"", "status_file = \"" + status + "\"");
    std::ofstream(config) << text;
  }
  // A sweep recorded earlier (the simulated unit at 16 C, the configuration's ambient).
  const std::string sweep_err = dir + "/calibrate_install_sweep.err";
  REQUIRE(exit_status(spawn_gyrotc({"simulate", "--profile", "selfcal", "--ambient-c", "16", "--sample-rate-hz", "50",
                                    "--out", dir + "/calibrate_install_sweep"},
                                   sweep_err)) == 0);
  // The daemon must outlive calibrate's fit, which took over 60 s under the
  // sanitizers on a loaded 2-core machine (Debian 13); the SIGTERM below ends it.
  const pid_t daemon = spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "600"}, err);
  REQUIRE(daemon > 0);
  REQUIRE(wait_for_text(err, "running on"));
  REQUIRE(wait_for_text(status, "\"running\": true"));
  const std::string out = dir + "/calibrate_install_new.toml";
  const std::string calibrate_err = dir + "/calibrate_install.err";
  CHECK(exit_status(spawn_gyrotc({"calibrate", "--data", dir + "/calibrate_install_sweep/record.csv", "--config", config,
                                  "--install", "--out", out},
                                 calibrate_err)) == 0);
  CHECK(read_text(calibration) == read_text(out));
  CHECK(wait_for_text(err, "SIGHUP: calibration reloaded from " + calibration));
  kill(daemon, SIGTERM);
  CHECK(exit_status(daemon) == 0);
}

#endif
