// `gyrotc record --experiment tune` on the simulated board in real time
// (issue 23): the identification experiment runs through the real-time
// runner, drives the TEC, and SIGTERM in the middle of it ends in safe-off.
#include <signal.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "gyrotc_process.hpp"

using namespace gyrotc::test;

// The test starts a `gyrotc` child with the runner's threads: native only
// under qemu (see link.cmake).
#if !defined(GYROTC_NO_GUEST_THREADS)

TEST_CASE("record --experiment tune drives the TEC through the real-time runner, SIGTERM mid-experiment ends in safe-off") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string csv = dir + "/record_experiment.csv";
  const std::string summary = dir + "/record_experiment_summary.json";
  const std::string err = dir + "/record_experiment.err";
  std::remove(csv.c_str());
  std::remove(summary.c_str());
  const pid_t pid = spawn_gyrotc({"record", "--config", gyrotc::test::sim_config_copy("record_experiment_config"),
                                  "--experiment", "tune", "--out", csv, "--allow-non-rt", "--summary-json", summary},
                                 err);
  REQUIRE(pid > 0);
  REQUIRE(wait_for_text(err, "identification experiment: at most"));
  // After its rest (0 A), the experiment drives full heating current towards
  // the setpoint: wait (bounded) for that in the record, then stop it there.
  bool driving = false;
  for (int i = 0; i < 300 && !driving; ++i) {
    for (double a : record_tec_a(csv)) driving = driving || a > 0.5;
    if (!driving) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  CHECK(driving);
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 0);
  CHECK(read_text(err).find("SIGTERM") != std::string::npos);
  std::ifstream in(summary);
  REQUIRE(in.good());
  const nlohmann::json j = nlohmann::json::parse(in);
  CHECK(j.at("stopped_by") == "SIGTERM");
  CHECK(j.at("final_state").at("tec_current_a").get<double>() == Approx(0.0).margin(1e-3));
  CHECK(j.at("final_state").at("opa548_enabled") == false);
  std::ifstream header_in(csv);
  std::string header;
  REQUIRE(std::getline(header_in, header));
  CHECK(header == "time_s,sensor_c,ambient_c,gyro_mv,rate_dps_compensated,tec_a,setpoint_c,flags");
}

TEST_CASE("record --experiment tune refuses --pid: the experiment drives the TEC itself") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string err = dir + "/record_experiment_pid_off.err";
  const pid_t pid = spawn_gyrotc({"record", "--config", gyrotc::test::config_file("gyrotc-sim.toml"),
                                  "--experiment", "tune", "--pid", "off", "--out", dir + "/unused.csv", "--allow-non-rt"},
                                 err);
  CHECK(exit_status(pid) == 2);
  CHECK(read_text(err).find("--pid and --experiment: choose one") != std::string::npos);
}

TEST_CASE("run --controller with a file that is not a controller file exits 2 naming the file") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string bad = dir + "/not_a_controller.toml";
  std::ofstream(bad) << "format = \"gyrotc-plant\"\n";
  const std::string err = dir + "/run_bad_controller.err";
  const pid_t pid = spawn_gyrotc({"run", "--config", gyrotc::test::config_file("gyrotc-sim.toml"),
                                  "--controller", bad, "--allow-non-rt", "--duration", "1"},
                                 err);
  CHECK(exit_status(pid) == 2);
  CHECK(read_text(err).find(bad + ": not a controller file") != std::string::npos);
}

#endif  // !GYROTC_NO_GUEST_THREADS
