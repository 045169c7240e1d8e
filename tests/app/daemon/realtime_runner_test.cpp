#include <signal.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <iterator>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc_catch.hpp"
#include "gyrotc_process.hpp"
#include "observer_controller_file.hpp"
#include "test_paths.hpp"

using namespace gyrotc;
using gyrotc::app::RealtimeRunner;
using gyrotc::test::exit_status;
using gyrotc::test::read_text;
using gyrotc::test::spawn_gyrotc;
using gyrotc::test::wait_for_text;

// Every test here starts the runner's threads (in process or in a `gyrotc`
// child): native only under qemu (see link.cmake).
#if !defined(GYROTC_NO_GUEST_THREADS)

namespace {

const std::string kSimConfig = gyrotc::test::config_file("gyrotc-sim.toml");

struct SimRig {
  app::DaemonConfig config = app::load_daemon_config(kSimConfig);
  app::BoardInstance instance = app::make_board(config.board, app::SimTiming::realtime);
  fit::Compensator compensator{fit::BiasModel::paper_reference()};
  app::Controller controller{config.controller, compensator};

  app::RealtimeRunnerOptions options(double duration_s, bool allow_non_rt) const {
    app::RealtimeRunnerOptions o;
    o.realtime = config.realtime;
    o.realtime.priority = 10;
    o.realtime.lock_memory = false;
    o.realtime.allow_non_rt = allow_non_rt;
    o.duration_s = duration_s;
    o.sample_period_s = hal::Ads1251::kClocksPerSample / config.board.devices.adc.fclk_hz;
    o.output_period_s = 0.5;
    return o;
  }
  bool tec_off() const {
    const hal::SimBoard& sim = *instance.sim_board;
    const double mid_v = 0.5 * config.board.devices.tec_dac.vref_v;
    return !sim.opa548_chip().output_enabled() && std::fabs(sim.tec_dac_chip().output_v() - mid_v) < 1e-3;
  }
};

void wait_finished(const RealtimeRunner& runner) {
  // A bound on the test, not a timing assertion: the runs below last seconds.
  for (int i = 0; i < 600 && !runner.finished(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
}

}  // namespace

TEST_CASE("a run on the real-time simulated board heats, then ends with the TEC at 0 A and the OPA548 disabled") {
  SimRig rig;
  RealtimeRunner runner(rig.instance.board(), rig.controller, rig.options(4.5, true));
  std::vector<app::OutputRow> rows;
  runner.add_row_sink([&rows](const app::OutputRow& row) { rows.push_back(row); });
  runner.start();
  wait_finished(runner);
  REQUIRE(runner.finished());
  runner.stop();
  const app::LoopCounters c = runner.counters();
  CHECK(c.samples > 0);
  CHECK(c.pid_ticks >= 1);
  CHECK(c.readings >= 1);
  CHECK(runner.latency().count == c.samples);
  REQUIRE_FALSE(rows.empty());
  // The casing starts at 16 C, below the 55 C setpoint: the PID heated.
  bool heated = false;
  for (const auto& row : rows) heated = heated || row.tec_a > 0.0;
  CHECK(heated);
  CHECK(rig.tec_off());
  CHECK((rig.controller.flags() & app::kFlagTecOff) == 0);  // it was the runner's stop, not a fault
}

TEST_CASE("without SCHED_FIFO permission the runner refuses, naming --allow-non-rt, and leaves the TEC off") {
  SimRig rig;
  RealtimeRunner runner(rig.instance.board(), rig.controller, rig.options(0.5, false));
  try {
    runner.start();
  } catch (const app::RuntimeFailure& e) {
    CHECK(std::string(e.what()).find("--allow-non-rt") != std::string::npos);
    CHECK(rig.tec_off());
    WARN(std::string("SCHED_FIFO not permitted here (the refusal was checked): ") + e.what());
    return;
  }
  CHECK(runner.is_realtime());
  wait_finished(runner);
  runner.stop();
  CHECK(rig.tec_off());
  SUCCEED("SCHED_FIFO is permitted here: the refusal path was not exercised");
}

TEST_CASE("SIGTERM to a running `gyrotc run` on the simulated board: exit 0, TEC off, summary written") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_sigterm.toml";
  const std::string summary = dir + "/daemon_sigterm_summary.json";
  const std::string stream = dir + "/daemon_sigterm_stream.csv";
  {
    std::string text = gyrotc::test::sim_config_text("daemon_sigterm");
    // Lines to a file (not the test's stdout), every 0.2 s.
    const std::string from = "stream = \"stdout\"";
    text.replace(text.find(from), from.size(), "stream = \"file\"\npath = \"" + stream + "\"");
    const std::string period = "period_s = 1.0                 # one line";
    text.replace(text.find(period), period.size(), "period_s = 0.2  # one line");
    const std::string calibration = "file = \"calibration.toml\"";
    text.replace(text.find(calibration), calibration.size(),
                 "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
    std::ofstream(config) << text;
  }
  std::remove(summary.c_str());
  std::remove(stream.c_str());
  const std::string exe = gyrotc::test::gyrotc_exe();
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    execl(exe.c_str(), exe.c_str(), "run", "--config", config.c_str(), "--allow-non-rt", "--duration", "60",
          "--summary-json", summary.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until the daemon streams lines (it runs), then stop it.
  for (int i = 0; i < 300; ++i) {
    std::ifstream lines(stream);
    std::string header, first;
    if (std::getline(lines, header) && std::getline(lines, first)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(pid, SIGTERM);
  int status = 0;
  REQUIRE(waitpid(pid, &status, 0) == pid);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  std::ifstream in(summary);
  REQUIRE(in.good());
  const nlohmann::json j = nlohmann::json::parse(in);
  CHECK(j.at("stopped_by") == "SIGTERM");
  CHECK(j.at("samples").get<std::uint64_t>() > 0);
  CHECK(j.at("final_state").at("tec_current_a").get<double>() == Approx(0.0).margin(1e-3));
  CHECK(j.at("final_state").at("opa548_enabled") == false);
  for (const char* key : {"min", "avg", "p50", "p99", "max"}) CHECK(j.at("latency_us").contains(key));
  CHECK(j.contains("overruns"));
  CHECK(j.contains("missed_drdy"));
  for (const char* key : {"late_reads", "spurious_edges", "missed_conversions"}) CHECK(j.contains(key));
  CHECK(j.at("sim_adc").at("accepted_samples").get<std::uint64_t>() == j.at("samples").get<std::uint64_t>());
  CHECK(j.at("sim_adc").at("accepted_corrupted_samples").get<std::uint64_t>() == 0);
}

TEST_CASE("stop puts the TEC in the safe state without waiting for a DS18B20 read in progress") {
  // A casing sensor whose conversion hangs until released, and a TEC stage
  // that notes when it was made safe.
  struct HangingSensor final : hal::TemperatureSensor {
    std::atomic<bool> reading{false};
    std::atomic<bool> release{false};
    hal::TemperatureReading do_read() override {
      reading = true;
      while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(5));
      return {};
    }
    std::string_view do_name() const noexcept override { return "hanging"; }
  } sensor;
  struct NotingTec final : hal::TecDriver {
    explicit NotingTec(hal::TecDriver& tec) : inner(tec) {}
    hal::TecDriver& inner;
    std::atomic<bool> made_safe{false};
    hal::Status do_set_current_a(double a) noexcept override { return inner.set_current_a(a); }
    hal::Status do_enable(bool on) noexcept override { return inner.enable(on); }
    hal::Result<hal::ThermalStatus> do_thermal_status() noexcept override { return inner.thermal_status(); }
    bool do_senses_thermal() const noexcept override { return inner.senses_thermal(); }
    hal::Status do_safe_off() noexcept override {
      made_safe = true;
      return inner.safe_off();
    }
  };
  SimRig rig;
  hal::Board sim = rig.instance.board();
  NotingTec tec(sim.tec);
  const hal::Board board{sim.adc, sensor, nullptr, sim.rate_dac, tec, sim.clock};
  RealtimeRunner runner(board, rig.controller, rig.options(0.0, true));
  runner.start();
  for (int i = 0; i < 200 && !sensor.reading; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  REQUIRE(sensor.reading);
  tec.made_safe = false;  // start() made it safe once
  std::thread stopper([&runner] { runner.stop(); });
  for (int i = 0; i < 200 && !tec.made_safe; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  CHECK(tec.made_safe);       // safe while the sensor thread still hangs in its read
  CHECK_FALSE(sensor.release);
  CHECK(rig.tec_off());
  sensor.release = true;
  stopper.join();
}

TEST_CASE("SIGHUP reloads the calibration file, an invalid one is rejected, logged, and the run goes on") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_sighup.toml";
  const std::string calibration = dir + "/daemon_sighup_calibration.toml";
  const std::string err = dir + "/daemon_sighup.err";
  std::ofstream(calibration) << read_text(gyrotc::test::data_file("calibration_table2.toml"));
  {
    std::string text = gyrotc::test::sim_config_text("daemon_sighup");
    const std::string from = "file = \"calibration.toml\"";
    text.replace(text.find(from), from.size(), "file = \"" + calibration + "\"");
    const std::string stream = "stream = \"stdout\"";
    text.replace(text.find(stream), stream.size(), "stream = \"none\"");
    std::ofstream(config) << text;
  }
  const pid_t pid = spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "60"}, err);
  REQUIRE(pid > 0);
  REQUIRE(wait_for_text(err, "running on"));
  kill(pid, SIGHUP);
  CHECK(wait_for_text(err, "calibration reloaded from " + calibration));
  std::ofstream(calibration) << "format = \"not-a-calibration\"\n";
  kill(pid, SIGHUP);
  CHECK(wait_for_text(err, "SIGHUP: nothing reloaded, the running configuration stays: " + calibration));
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 0);
  CHECK(read_text(err).find("SIGTERM") != std::string::npos);
}

TEST_CASE("SIGHUP applies a new setpoint and gains, and names a changed key that takes a restart") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_sighup_control.toml";
  const std::string err = dir + "/daemon_sighup_control.err";
  const auto write_config = [&](double setpoint_c, int seed) {
    std::string text = gyrotc::test::sim_config_text("daemon_sighup_gains");
    const auto set = [&text](const std::string& from, const std::string& to) {
      text.replace(text.find(from), from.size(), to);
    };
    set("file = \"calibration.toml\"", "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
    set("stream = \"stdout\"", "stream = \"none\"");
    set("setpoint_c = 55.0", "setpoint_c = " + std::to_string(setpoint_c));
    set("seed = 1 ", "seed = " + std::to_string(seed) + " ");
    std::ofstream(config) << text;
  };
  write_config(55.0, 1);
  const pid_t pid = spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "60"}, err);
  REQUIRE(pid > 0);
  REQUIRE(wait_for_text(err, "running on"));
  write_config(50.0, 7);
  kill(pid, SIGHUP);
  CHECK(wait_for_text(err, "SIGHUP: control reloaded (from the next PID period, bumpless): PID, setpoint 50.00 C"));
  CHECK(wait_for_text(err, "SIGHUP: sim.seed changed in " + config + ": it takes a restart"));
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 0);
}

TEST_CASE("SIGHUP with another model-based loop's controller file hands the running loop over to it") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_sighup_observer.toml";
  const std::string controller = dir + "/daemon_sighup_observer_controller.toml";
  const std::string err = dir + "/daemon_sighup_observer.err";
  const auto write_controller = [&](double setpoint_c) {
    gyrotc::app::ControllerFile file = gyrotc::test::observer_controller_file();
    file.setpoint_c = setpoint_c;
    std::ofstream(controller) << gyrotc::app::format_controller_file(file);
  };
  write_controller(55.0);
  {
    std::string text = gyrotc::test::sim_config_text("daemon_sighup_observer");
    const auto set = [&text](const std::string& from, const std::string& to) {
      text.replace(text.find(from), from.size(), to);
    };
    set("file = \"calibration.toml\"", "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
    set("stream = \"stdout\"", "stream = \"none\"");
    // The controller file in place of [control]'s own setpoint, gains, period and options.
    static const std::regex replaced(
        "(setpoint_c|kp|ki|kd|period_s|xi_c|feed_forward_a_per_c|feed_forward_lag_s|setpoint_ramp_c_per_s) *=.*");
    std::string kept;
    std::string section;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind('[', 0) == 0) section = line;
      if (section == "[control]" && std::regex_match(line, replaced)) continue;
      kept += line + "\n";
      if (line == "[control]") kept += "controller_file = \"" + controller + "\"\n";
    }
    std::ofstream(config) << kept;
  }
  const pid_t pid = spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "60"}, err);
  REQUIRE(pid > 0);
  const bool running = wait_for_text(err, "running on");
  INFO(read_text(err));
  REQUIRE(running);
  write_controller(50.0);  // another setpoint: another design, another loop
  kill(pid, SIGHUP);
  CHECK(wait_for_text(err, "SIGHUP: control reloaded (from the next PID period, bumpless): on, setpoint 50.00 C, "
                           "model-based loop"));
  CHECK(wait_for_text(err, "a new model or design taking over from the running loop"));
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 0);
  CHECK(read_text(err).find("takes a restart") == std::string::npos);
}

TEST_CASE("SIGHUP moves the outputs: a stream turned on, the record and the status file to new paths") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_sighup_outputs.toml";
  const std::string err = dir + "/daemon_sighup_outputs.err";
  const std::string first_csv = dir + "/daemon_sighup_first.csv";
  const std::string second_csv = dir + "/daemon_sighup_second.csv";
  const std::string stream = dir + "/daemon_sighup_stream.csv";
  const std::string first_status = dir + "/daemon_sighup_first.json";
  const std::string second_status = dir + "/daemon_sighup_second.json";
  for (const std::string& f : {first_csv, second_csv, stream, first_status, second_status}) std::filesystem::remove(f);
  const auto write_config = [&](const std::string& stream_line, const std::string& csv, const std::string& status) {
    std::string text = read_text(kSimConfig);
    const auto set = [&text](const std::string& from, const std::string& to) {
      text.replace(text.find(from), from.size(), to);
    };
    set("file = \"calibration.toml\"", "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
    set("stream = \"stdout\"", stream_line);
    set("record_csv = \"\"", "record_csv = \"" + csv + "\"");
    set("status_file = \"/tmp/gyrotc-sim.status.json\"", "status_file = \"" + status + "\"");
    std::ofstream(config) << text;
  };
  write_config("stream = \"none\"", first_csv, first_status);
  const pid_t pid = spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "60"}, err);
  REQUIRE(pid > 0);
  REQUIRE(wait_for_text(err, "running on"));
  REQUIRE(wait_for_text(first_csv, "\n"));  // a row: the casing was read
  write_config("stream = \"file\"\npath = \"" + stream + "\"", second_csv, second_status);
  kill(pid, SIGHUP);
  CHECK(wait_for_text(err, "SIGHUP: outputs reloaded: stream file " + stream + ", record " + second_csv));
  CHECK(wait_for_text(second_csv, "\n"));
  CHECK(wait_for_text(stream, "\n"));
  CHECK(wait_for_text(second_status, "\"running\": true"));
  kill(pid, SIGTERM);
  CHECK(exit_status(pid) == 0);
  CHECK_FALSE(std::filesystem::exists(first_status));  // it would only go stale
  CHECK(read_text(first_csv).rfind("time_s,", 0) == 0);
  CHECK(read_text(second_csv).rfind("time_s,", 0) == 0);
  CHECK(read_text(stream).rfind("time_s,", 0) == 0);
  CHECK(read_text(err).find("takes a restart") == std::string::npos);
}

TEST_CASE("the daemon's own CSV record moves to .1 past record_max_mb and starts again with its header") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string config = dir + "/daemon_rotate.toml";
  const std::string csv = dir + "/daemon_rotate.csv";
  std::filesystem::remove(csv + ".1");
  {
    std::string text = gyrotc::test::sim_config_text("daemon_rotate");
    const auto set = [&text](const std::string& from, const std::string& to) {
      text.replace(text.find(from), from.size(), to);
    };
    set("file = \"calibration.toml\"", "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
    set("stream = \"stdout\"", "stream = \"none\"");
    set("period_s = 1.0                 # one line", "period_s = 0.2                 # one line");
    set("record_csv = \"\"", "record_csv = \"" + csv + "\"");
    set("record_max_mb = 100.0", "record_max_mb = 0.0005");  // about 7 rows
    std::ofstream(config) << text;
  }
  CHECK(exit_status(spawn_gyrotc({"run", "--config", config, "--allow-non-rt", "--duration", "8"},
                                 dir + "/daemon_rotate.err")) == 0);
  const std::string older = read_text(csv + ".1");
  const std::string current = read_text(csv);
  CHECK(older.rfind("time_s,", 0) == 0);
  CHECK(current.rfind("time_s,", 0) == 0);
  CHECK(older.size() <= 500);
  CHECK(current.size() <= 500);
  CHECK(read_text(dir + "/daemon_rotate.err").find("reached record_max_mb, moved to " + csv + ".1") !=
        std::string::npos);
}

TEST_CASE("gyrotc safe-off on the simulated board exits 0, a bad configuration exits 2 naming the key") {
  const std::string dir = gyrotc::test::scratch_dir();
  CHECK(exit_status(spawn_gyrotc({"safe-off", "--config", kSimConfig}, dir + "/daemon_safe_off.err")) == 0);
  const std::string bad = dir + "/daemon_bad.toml";
  std::ofstream(bad) << "hal = \"sim\"\n[control]\nperiod_s = -2\n";
  const std::string err = dir + "/daemon_bad.err";
  CHECK(exit_status(spawn_gyrotc({"run", "--config", bad, "--allow-non-rt"}, err)) == 2);
  CHECK(read_text(err).find("daemon_bad.toml:3: control.period_s: must be within") != std::string::npos);
}

TEST_CASE("gyrotc record writes the columns gyrotc fit reads, one row per period with a casing reading") {
  const std::string dir = gyrotc::test::scratch_dir();
  const std::string csv = dir + "/daemon_record.csv";
  std::remove(csv.c_str());
  REQUIRE(exit_status(spawn_gyrotc({"record", "--config", gyrotc::test::sim_config_copy("daemon_record_config"), "--out", csv,
                                    "--duration", "3", "--pid", "off",
                                    "--allow-non-rt"},
                                   dir + "/daemon_record.err")) == 0);
  std::ifstream in(csv);
  std::string header;
  REQUIRE(std::getline(in, header));
  CHECK(header == "time_s,sensor_c,ambient_c,gyro_mv,rate_dps_compensated,tec_a,setpoint_c,flags");
  int rows = 0;
  for (std::string line; std::getline(in, line);) {
    ++rows;
    const double sensor_c = std::stod(line.substr(line.find(',') + 1));
    CHECK(sensor_c == Approx(16.0).margin(1.0));  // the casing starts at 16 C; the TEC stays off
    CHECK(line.find("nan") == std::string::npos);
  }
  CHECK(rows >= 1);
}

#endif  // !GYROTC_NO_GUEST_THREADS
