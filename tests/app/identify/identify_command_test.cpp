#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/record_generator.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/errors.hpp"
#include "gyrotc/app/plant_file.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "run_command.hpp"

namespace fs = std::filesystem;
using gyrotc::app::InputError;

namespace {

const std::string kTable1 = gyrotc::test::data_file("table1_resonance_q.csv");

fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / ("gyrotc_identify_" + std::to_string(::getpid()) + "_" + name);
}

std::string run_identify(const std::vector<std::string>& args) {
  return gyrotc::test::run_command(gyrotc::app::add_identify_command, "identify", args);
}

std::string read_file(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

TEST_CASE("identify --target drive_q on Table 1 names gas_desorption and shrinks the gap 5x (JSON)") {
  const auto j = nlohmann::json::parse(run_identify({"--data", kTable1, "--target", "drive_q", "--json"}));
  CHECK(j["target"] == "drive_q");
  CHECK(j["verdict"] == "gas_desorption");
  CHECK(j["baseline"]["rms"].get<double>() == Approx(0.29).margin(0.02));  // Eq. 10 alone: ~29 %
  CHECK(j["shrink"].get<double>() >= 5.0);
  REQUIRE(j["added"].size() == 1);
  CHECK(j["added"][0]["effect"] == "gas_desorption");
  CHECK(j["added"][0]["params"].contains("ea_kj_per_mol"));
  CHECK(j["added"][0]["stderr"].contains("a"));
  CHECK(j["final"].contains("whiteness_p"));
  CHECK(j["regions"].size() > 0);
}

TEST_CASE("identify --target drive_freq_hz on Table 1 answers none") {
  const auto j = nlohmann::json::parse(run_identify({"--data", kTable1, "--target", "drive_freq_hz", "--json"}));
  CHECK(j["verdict"] == "none");
  CHECK(j["added"].empty());
}

TEST_CASE("identify --report writes a readable report naming the verdict") {
  const fs::path dir = temp_path("report");
  run_identify({"--data", kTable1, "--target", "sense_q", "--report", dir.string()});
  const std::string report = read_file(dir / "report.md");
  CHECK(report.find("gas_desorption") != std::string::npos);
  CHECK(fs::exists(dir / "curves.csv"));
  fs::remove_all(dir);
}

TEST_CASE("identify --report plots measured against both models and the residuals") {
  const fs::path dir = temp_path("report-plot");
  run_identify({"--data", kTable1, "--target", "sense_q", "--report", dir.string()});
  const std::string svg = read_file(dir / "plot.svg");
  fs::remove_all(dir);
  CHECK(svg.find("<svg") != std::string::npos);
  for (const char* label : {"measured", "baseline model", "final model", "baseline residual", "final residual"}) {
    INFO(label);
    CHECK(svg.find(label) != std::string::npos);
  }
}

TEST_CASE("identify on a static table without --target says which targets exist") {
  try {
    run_identify({"--data", kTable1});
    FAIL("no error");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("--target") != std::string::npos);
  }
}

TEST_CASE("identify --out-plant writes a plant description with the effect found switched on") {
  gyrotc::identify::RecordSpec spec;
  spec.duration_s = 3.0 * 3600.0;
  spec.seed = 4242;
  spec.effects.warm_up = gyrotc::model::WarmUpEffect{2.0, 600.0};
  const auto record = gyrotc::identify::generate_record(spec);
  const fs::path csv = temp_path("record.csv");
  {
    std::ofstream out(csv);
    out << "time_s,ambient_c,sensor_c,gyro_mv\n";
    for (std::size_t i = 0; i < record.time_s.size(); ++i) {
      out << record.time_s[i] << "," << record.ambient_c[i] << "," << record.sensor_c[i] << ","
          << record.gyro_mv[i] << "\n";
    }
  }
  const fs::path plant = temp_path("plant.toml");
  const auto j = nlohmann::json::parse(run_identify({"--data", csv.string(), "--out-plant", plant.string(), "--json"}));
  CHECK(j["verdict"] == "warm_up");
  const auto params = gyrotc::app::load_plant(plant.string());
  REQUIRE(params.effects.warm_up.has_value());
  CHECK(params.effects.warm_up->a_mv == Approx(2.0).epsilon(0.15));
  CHECK_FALSE(params.effects.thermal_lag.has_value());
  fs::remove(csv);
  fs::remove(plant);
}
