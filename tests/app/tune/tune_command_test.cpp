// `gyrotc tune` on a record as the board writes it (the identification
// experiment on the simulated board, lockstep at 20 Hz: the thermal behaviour
// does not depend on the gyro's sample rate).
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <functional>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "gyrotc/app/workflows/tuning.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"
#include "run_command.hpp"

using namespace gyrotc;
using gyrotc::test::input_error_of;
using gyrotc::test::run_command;

namespace {

// One folder per process: ctest runs the test cases as parallel processes.
const std::string kDir = gyrotc::test::scratch_dir() + "/tune_command_" + std::to_string(::getpid());

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The experiment on the nominal plant, recorded as a board records it.
const std::string& record_csv() {
  static const std::string path = [] {
    std::filesystem::create_directories(kDir);
    const app::SimulationResult r = app::simulate_tune_experiment(model::PlantParams{}, 16.0, 20.0);
    const std::string p = kDir + "/record.csv";
    app::write_board_record_csv(r.rows, p);
    return p;
  }();
  return path;
}

// The record with one column's cells replaced by f(row index, old cell).
std::string rewrite_column(const std::string& name, const std::string& column,
                           const std::function<std::string(std::size_t, const std::string&)>& f,
                           bool drop = false) {
  std::istringstream in(read_text(record_csv()));
  std::ostringstream out;
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  {
    std::stringstream cells(line);
    for (std::string c; std::getline(cells, c, ',');) header.push_back(c);
  }
  std::size_t at = header.size();
  for (std::size_t k = 0; k < header.size(); ++k) at = header[k] == column ? k : at;
  auto emit = [&](const std::vector<std::string>& cells) {
    bool first = true;
    for (std::size_t k = 0; k < cells.size(); ++k) {
      if (drop && k == at) continue;
      out << (first ? "" : ",") << cells[k];
      first = false;
    }
    out << "\n";
  };
  emit(header);
  for (std::size_t row = 0; std::getline(in, line); ++row) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    for (std::string c; std::getline(s, c, ',');) cells.push_back(c);
    if (at < cells.size() && !drop) cells[at] = f(row, cells[at]);
    emit(cells);
  }
  const std::string path = kDir + "/" + name;
  std::ofstream(path) << out.str();
  return path;
}

// A short room for simulate runs.
std::string flat_profile() {
  std::filesystem::create_directories(kDir);
  const std::string path = kDir + "/flat.csv";
  std::ofstream(path) << "time_s,ambient_c\n0,16\n120,16\n";
  return path;
}

// The controller part of a controller file (its [identified] table names the record).
std::string controller_part(const std::string& path) {
  const std::string text = read_text(path);
  return text.substr(0, text.find("[identified]"));
}

}  // namespace

TEST_CASE("gyrotc tune writes a controller file that simulate can run, and reports the model and the design") {
  const std::string out = kDir + "/unit/controller.toml";  // its folder is created
  const std::string printed = run_command(app::add_tune_command, "tune", {"--data", record_csv(), "--out", out, "--json"});
  const nlohmann::json j = nlohmann::json::parse(printed);
  CHECK(j.at("fit").at("rms_c").get<double>() < 0.03);
  CHECK(j.at("parameters").size() >= 9);
  for (const auto& p : j.at("parameters")) CHECK(p.contains("std_error"));
  CHECK(j.at("design").at("feed_forward_a_per_c").get<double>() > 0.0);
  // The record pins the shell down: the feed-forward answers the ambient through it.
  for (const auto& p : j.at("parameters")) {
    if (p.at("name") != "shell_tau_s") continue;
    REQUIRE(p.at("determined").get<bool>());
    CHECK(j.at("design").at("feed_forward_lag_s").get<double>() == p.at("value").get<double>());
  }
  CHECK(j.contains("identify_s"));
  const app::ControllerFile c = app::load_controller_file(out);
  CHECK(c.setpoint_c == 55.0);
  CHECK(c.kp > 0.0);
  CHECK(c.rail.known);
  const std::string sim =
      run_command(app::add_simulate_command, "simulate",
                  {"--profile", flat_profile(), "--controller", out, "--sample-rate-hz", "20", "--json"});
  CHECK(nlohmann::json::parse(sim).at("controller") == out);
}

TEST_CASE("a stage that clips below the configured current limit has its limit identified, and tune says to configure it") {
  model::PlantParams plant;
  plant.current_limit_a = 0.6;  // the OPA548's ILIM, below the 1 A the controller is configured for
  std::filesystem::create_directories(kDir);
  const std::string record = kDir + "/clipped.csv";
  app::write_board_record_csv(app::simulate_tune_experiment(plant, 16.0, 20.0, {}, 1.0).rows, record);
  const nlohmann::json j = nlohmann::json::parse(
      run_command(app::add_tune_command, "tune", {"--data", record, "--out", kDir + "/clipped.toml", "--json"}));
  const nlohmann::json& fit = j.at("fit");
  INFO("fit rms " << fit.at("rms_c").get<double>() << " C");
  CHECK(fit.at("stage_limit_fitted").get<bool>());
  CHECK(fit.at("rms_c").get<double>() < 2.0 * fit.at("quantisation_rms_c").get<double>());
  double limit_a = 0.0;
  for (const auto& e : j.at("parameters")) {
    if (e.at("name") == "stage_limit_a") limit_a = e.at("value").get<double>();
  }
  CHECK(limit_a == Approx(0.6).epsilon(0.02));
  bool told = false;
  for (const auto& w : j.at("warnings")) {
    const std::string text = w.get<std::string>();
    told = told || (text.find("the stage gave at most") != std::string::npos &&
                    text.find("set [tec] current_limit_a to") != std::string::npos);
  }
  CHECK(told);
}

TEST_CASE("the controller tune designs holds the plant that made the record better than the seed's controller") {
  // Judged on the true plant, in closed loop, not by the design's own margins:
  // from 16 C to 55 C and held; the seed's controller on the same plant is the
  // yardstick (its in-band error is set by the 1/16 C reading steps it kicks on).
  const std::string out = kDir + "/held/controller.toml";
  (void)run_command(app::add_tune_command, "tune", {"--data", record_csv(), "--out", out});
  std::filesystem::create_directories(kDir);
  const std::string profile = kDir + "/flat_2400.csv";
  std::ofstream(profile) << "time_s,ambient_c\n0,16\n2400,16\n";
  auto run = [&](const std::string& controller) {
    return nlohmann::json::parse(run_command(app::add_simulate_command, "simulate",
                                             {"--profile", profile, "--controller", controller,
                                              "--sample-rate-hz", "20", "--json"}));
  };
  const nlohmann::json tuned = run(out);
  const nlohmann::json paper = run("paper");
  REQUIRE(tuned.at("settle_s").is_number());
  REQUIRE(paper.at("settle_s").is_number());
  CHECK(tuned.at("settle_s").get<double>() <= paper.at("settle_s").get<double>());
  CHECK(tuned.at("max_abs_error_c_in_band").get<double>() <= 0.05);
  CHECK(tuned.at("max_abs_error_c_in_band").get<double>() <= 0.5 * paper.at("max_abs_error_c_in_band").get<double>());
}

TEST_CASE("tune reads only the board's columns: the simulator's true temperatures change nothing") {
  // Add what only a simulation has, scrambled: tune must not look at it.
  std::string text = read_text(record_csv());
  std::istringstream in(text);
  std::ostringstream out;
  std::string line;
  std::getline(in, line);
  out << line << ",casing_c,die_c,tec_v\n";
  for (int row = 0; std::getline(in, line); ++row) out << line << "," << 90 - row % 7 << "," << row % 13 << ",-3\n";
  const std::string with_truth = kDir + "/with_truth.csv";
  std::ofstream(with_truth) << out.str();
  run_command(app::add_tune_command, "tune", {"--data", record_csv(), "--out", kDir + "/a.toml"});
  run_command(app::add_tune_command, "tune", {"--data", with_truth, "--out", kDir + "/b.toml"});
  CHECK(controller_part(kDir + "/a.toml") == controller_part(kDir + "/b.toml"));
}

TEST_CASE("a record without tec_a is refused, saying which column is missing and what tune needs") {
  const std::string path = rewrite_column("no_tec.csv", "tec_a", {}, true);
  const std::string why = input_error_of([&] { run_command(app::add_tune_command, "tune", {"--data", path, "--out", kDir + "/x.toml"}); });
  CHECK(why.find("no_tec.csv: no column 'tec_a'") != std::string::npos);
  CHECK(why.find("time_s, sensor_c and tec_a") != std::string::npos);
}

TEST_CASE("a record from a board without the ambient sensor gives a controller without feed-forward") {
  const std::string path = rewrite_column("no_ambient.csv", "ambient_c", [](std::size_t, const std::string&) { return std::string("nan"); });
  run_command(app::add_tune_command, "tune", {"--data", path, "--out", kDir + "/no_ambient.toml"});
  CHECK(app::load_controller_file(kDir + "/no_ambient.toml").feed_forward_a_per_c == 0.0);
}

TEST_CASE("the model-based loop from a record without the ambient sensor is refused, naming the file and the way out") {
  const std::string path = rewrite_column("no_ambient_observer.csv", "ambient_c",
                                          [](std::size_t, const std::string&) { return std::string("nan"); });
  const std::string why = input_error_of([&] {
    run_command(app::add_tune_command, "tune", {"--data", path, "--loop", "observer", "--out", kDir + "/x.toml"});
  });
  CHECK(why.find("no_ambient_observer.csv: --loop observer needs the ambient sensor") != std::string::npos);
  CHECK(why.find("--loop pid works without") != std::string::npos);
}

TEST_CASE("tune --loop observer writes a model-based loop's file and reports the loop it designed") {
  const std::string out = kDir + "/observer.toml";
  const std::string printed =
      run_command(app::add_tune_command, "tune", {"--data", record_csv(), "--loop", "observer", "--out", out});
  CHECK(printed.find("model-based loop (type = \"observer\")") != std::string::npos);
  CHECK(printed.find("stable below 1") != std::string::npos);
  const app::ControllerFile c = app::load_controller_file(out);
  REQUIRE(c.observer.has_value());
  CHECK(c.period_s == 1.0);
  CHECK(c.observer->spec.reading_step_c == 0.0625);
  CHECK(c.stuck_min_drive_a.has_value());
}

TEST_CASE("a record whose current never moves is refused as without excitation, naming the file") {
  const std::string path = rewrite_column("constant.csv", "tec_a", [](std::size_t, const std::string&) { return std::string("0.25"); });
  const std::string why = input_error_of([&] { run_command(app::add_tune_command, "tune", {"--data", path, "--out", kDir + "/x.toml"}); });
  CHECK(why.find("constant.csv: no excitation") != std::string::npos);
}

TEST_CASE("a record whose casing reading never moves is refused as flat") {
  const std::string path = rewrite_column("flat_sensor.csv", "sensor_c", [](std::size_t, const std::string&) { return std::string("24.5"); });
  const std::string why = input_error_of([&] { run_command(app::add_tune_command, "tune", {"--data", path, "--out", kDir + "/x.toml"}); });
  CHECK(why.find("flat_sensor.csv: flat record") != std::string::npos);
}

TEST_CASE("a record with a cell that is not a number is refused naming its line") {
  const std::string path = rewrite_column("bad_cell.csv", "sensor_c", [](std::size_t row, const std::string& cell) {
    return row == 41 ? std::string("hot") : cell;
  });
  const std::string why = input_error_of([&] { run_command(app::add_tune_command, "tune", {"--data", path, "--out", kDir + "/x.toml"}); });
  CHECK(why.find("bad_cell.csv:43: column 'sensor_c'") != std::string::npos);
}

TEST_CASE("simulate --profile tune on a TEC wired the wrong way round stops in the approach, keeps the record and fails saying why") {
  model::PlantParams plant;
  model::ThermalNetwork n;
  n.nodes = {{"sink", 190.0, 0.0}, {"casing", 175.0, 0.3}};
  n.links = {{model::kAmbientNode, 0, 0.55}, {0, 1, 0.03}};
  n.tec_from = 1;  // the TEC's hot side on the casing
  n.tec_to = 0;
  n.casing_sensor = model::NetworkSensor{1, 5.0, 0.0, 0.0};
  n.ambient_sensor = model::NetworkSensor{model::kAmbientNode, 0.0, 0.0, 0.0};
  n.gyro_node = 1;
  plant.network = n;
  std::filesystem::create_directories(kDir);
  const std::string plant_path = kDir + "/reversed_plant.toml";
  app::save_plant(plant, plant_path);
  const std::string out = kDir + "/reversed";
  std::string why;
  try {
    run_command(app::add_simulate_command, "simulate",
                {"--profile", "tune", "--plant", plant_path, "--sample-rate-hz", "20", "--out", out, "--json"});
  } catch (const app::RuntimeFailure& e) {
    why = e.what();
  }
  CHECK(why.find("wired the wrong way round") != std::string::npos);
  const std::string summary = read_text(out + "/summary.json");
  REQUIRE_FALSE(summary.empty());
  const nlohmann::json j = nlohmann::json::parse(summary);
  CHECK(j.at("experiment").at("wrong_way").get<bool>());
  CHECK(j.at("experiment").at("duration_s").get<double>() < 600.0);
  CHECK(std::filesystem::exists(out + "/record.csv"));
}

TEST_CASE("simulate --controller refuses what is neither a preset nor a controller file") {
  const std::string why = input_error_of([&] {
    run_command(app::add_simulate_command, "simulate", {"--profile", flat_profile(), "--controller", "fast"});
  });
  CHECK(why.find("--controller 'fast': neither paper, tuned, off, oracle nor a controller file") != std::string::npos);
}
