#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/record_generator.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
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

// The RMS of ln Q about seed Eq. 10 (Q = c T^-1/2, c fitted: the mean of
// ln Q + ln(T)/2), computed here from the table itself.
double eq10_log_rms(const std::string& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<double> r;
  while (std::getline(in, line)) {
    double temp = 0, f = 0, q = 0;
    std::sscanf(line.c_str(), "%lf,%lf,%lf", &temp, &f, &q);
    r.push_back(std::log(q) + 0.5 * std::log(temp + 273.15));
  }
  double mean = 0.0;
  for (double v : r) mean += v / static_cast<double>(r.size());
  double ss = 0.0;
  for (double v : r) ss += (v - mean) * (v - mean);
  return std::sqrt(ss / static_cast<double>(r.size()));
}

TEST_CASE("identify --target drive_q on Table 1 names gas_desorption and shrinks the gap 5x (JSON)") {
  const auto j = nlohmann::json::parse(run_identify({"--data", kTable1, "--target", "drive_q", "--json"}));
  CHECK(j["target"] == "drive_q");
  CHECK(j["verdict"] == "gas_desorption");
  CHECK(j["statement"] == "consistent with gas_desorption");
  CHECK(j["baseline"]["rms"].get<double>() == Approx(eq10_log_rms(kTable1)).epsilon(1e-6));
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

TEST_CASE("identify refuses a record that is mostly gap, naming the file and the reason") {
  const fs::path csv = temp_path("gapped.csv");
  {
    std::ofstream out(csv);
    out << "time_s,ambient_c,sensor_c,gyro_mv\n";
    for (int i = 0; i < 600; ++i) {
      const double t = i < 300 ? i : 20000.0 + i;  // 300 s, a 5.5 h gap, 300 s
      out << t << ",25," << 25.0 + 0.001 * i << "," << 80.0 + 0.01 * (i % 7) << "\n";
    }
  }
  try {
    run_identify({"--data", csv.string()});
    FAIL("no error");
  } catch (const InputError& e) {
    const std::string what = e.what();
    CHECK(what.find(csv.string()) == 0);
    CHECK(what.find("more than half is missing") != std::string::npos);
  }
  fs::remove(csv);
}

TEST_CASE("a plant description with an ambient sensitivity reads back what was written") {
  gyrotc::model::PlantParams params;
  params.effects.ambient_sensitivity = gyrotc::model::AmbientSensitivityEffect{0.07, 22.5};
  const auto back = gyrotc::app::parse_plant(gyrotc::app::format_plant(params), "p.toml");
  REQUIRE(back.effects.ambient_sensitivity.has_value());
  CHECK(back.effects.ambient_sensitivity->k_mv_per_c == 0.07);
  CHECK(back.effects.ambient_sensitivity->ref_c == 22.5);
}

TEST_CASE("a plant description's zero-bias curve reads back what was written, Table 2 is not written") {
  gyrotc::model::PlantParams params;
  CHECK(gyrotc::app::format_plant(params).find("zero_bias_c") == std::string::npos);
  params.zero_bias = gyrotc::model::ZeroBiasCurve({-40.0, 0.1, 85.0}, {80.0, 100.0 / 3.0, 90.0});
  const auto back = gyrotc::app::parse_plant(gyrotc::app::format_plant(params), "p.toml");
  CHECK(back.zero_bias == params.zero_bias);
}

TEST_CASE("a plant description's zero-bias curve is refused, naming the file, line and keys, when it is not one") {
  auto error = [](const std::string& text) {
    try {
      gyrotc::app::parse_plant(text, "p.toml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error("[gyro]\nzero_bias_c = [0.0, 10.0]\n") ==
        "p.toml:2: keys 'gyro.zero_bias_c' and 'gyro.zero_bias_mv' come together (the curve's temperatures and "
        "outputs)");
  CHECK(error("[gyro]\nzero_bias_c = [0.0, 10.0, 5.0]\nzero_bias_mv = [1.0, 2.0, 3.0]\n") ==
        "p.toml:2: keys 'gyro.zero_bias_c', 'gyro.zero_bias_mv': zero-bias curve: temperature 3 does not rise above "
        "the one before");
  CHECK(error("[gyro]\nzero_bias_c = 5.0\nzero_bias_mv = [1.0]\n") ==
        "p.toml:2: key 'gyro.zero_bias_c' must be a list of numbers");
  CHECK(error("[gyro]\nzero_bias_c = [0.0, \"x\"]\nzero_bias_mv = [1.0, 2.0]\n").find("p.toml:2: key "
                                                                                    "'gyro.zero_bias_c' must be a "
                                                                                    "number") == 0);
}

TEST_CASE("identify --out-plant writes a plant description with the effect found switched on") {
  gyrotc::identify::RecordSpec spec;
  spec.duration_s = 3.0 * 3600.0;
  spec.seed = 4242;
  spec.effects.warm_up = gyrotc::model::WarmUpEffect{2.0, 600.0};
  const auto record = gyrotc::identify::generate_record(spec);
  const fs::path csv = temp_path("record.csv");
  {
    // Every 10th second: a smaller record, quicker under the sanitizers.
    std::ofstream out(csv);
    out << "time_s,ambient_c,sensor_c,gyro_mv\n";
    for (std::size_t i = 0; i < record.time_s.size(); i += 10) {
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

namespace {

// What a user does to check identify: simulate the chamber programme (CSV
// text) with an effect switched on (a plant file's text), then identify the
// record against the default plant. Returns identify's arguments, without
// --json.
std::vector<std::string> simulate_hidden(const fs::path& dir, const std::string& programme, const std::string& hidden) {
  fs::create_directories(dir);
  std::ofstream(dir / "programme.csv") << programme;
  std::ofstream(dir / "hidden.toml") << hidden;
  std::ofstream(dir / "base.toml").flush();
  (void)gyrotc::test::run_command(gyrotc::app::add_simulate_command, "simulate",
                                  {"--profile", (dir / "programme.csv").string(), "--controller", "off", "--plant",
                                   (dir / "hidden.toml").string(), "--out", (dir / "meas").string()});
  return {"--data", (dir / "meas" / "simulation.csv").string(), "--plant", (dir / "base.toml").string()};
}

nlohmann::json identify_json(std::vector<std::string> args) {
  args.push_back("--json");
  return nlohmann::json::parse(run_identify(args));
}

// 36 C, then the chamber 30 <-> 42 C at 0.5 C/min with 20 min holds (6.2 h):
// the casing stays within 36..41 C.
const char* const kNarrowProgramme =
    "time_s,ambient_c\n0,36\n1800,36\n2520,30\n3720,30\n5160,42\n6360,42\n7800,30\n9000,30\n10440,42\n"
    "11640,42\n13080,30\n14280,30\n15720,42\n16920,42\n18360,30\n19560,30\n21000,42\n22200,42\n";

}  // namespace

TEST_CASE("identify names a 2 mV ramp hysteresis that simulate hid on a temperature triangle, and warns of the baseline's wander") {
  // Issue 74, as a user meets it: simulate with the effect switched on, then
  // identify against the default plant. The die follows the casing through
  // the plant's 40 s lag; the hysteresis' dT/dt must follow it there too
  // (answered ambient_sensitivity when it was the die's 60 s-smoothed rate).
  const fs::path dir = temp_path("triangle");
  const auto j = identify_json(simulate_hidden(
      dir,
      "time_s,ambient_c\n0,20\n1800,20\n7800,-30\n9600,-30\n21600,70\n23400,70\n35400,-30\n37200,-30\n"
      "43200,20\n45000,20\n",
      "[effects.ramp_hysteresis]\nh_mv = 2\nr0_c_per_s = 0.003\n"));
  CHECK(j["verdict"] == "ramp_hysteresis");
  REQUIRE(j["added"].size() == 1);
  CHECK(j["added"][0]["params"]["h_mv"].get<double>() == Approx(2.0).epsilon(0.1));
  CHECK(j["shrink"].get<double>() > 5.0);
  REQUIRE(j["noise_warnings"].size() == 1);
  CHECK(j["noise_warnings"][0].get<std::string>().find("baseline model's bias wander") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("identify names a rate sensitivity on a narrow range among the effects the record cannot tell apart") {
  // Issue 74: on the simulated board's narrow range a 300 mV per C/s rate
  // sensitivity was answered ambiguous:thermal_lag+ambient_sensitivity, the
  // truth named nowhere: its dT/dt over 60 s of the 0.0625 C reading flickered
  // more than the effect (p = 0.03), and passing, it stood 56 in BIC behind
  // the lag while confounded with the ambient sensitivity tied with it.
  const fs::path dir = temp_path("narrow_rate");
  const auto j =
      identify_json(simulate_hidden(dir, kNarrowProgramme, "[effects.rate_sensitivity]\nk_mv_per_c_per_s = 300\n"));
  const std::string verdict = j["verdict"].get<std::string>();
  INFO(verdict);
  CHECK(verdict.rfind("ambiguous:", 0) == 0);
  CHECK(verdict.find("rate_sensitivity") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("identify names the alternative a lag was told apart from, with their correlation and what would settle it") {
  // Issue 74: a 200 s lag that simulate hid on the narrow range, where the
  // casing follows the room through its lag and an ambient sensitivity
  // predicts nearly the same output.
  const fs::path dir = temp_path("narrow");
  const auto args = simulate_hidden(dir, kNarrowProgramme, "[effects.thermal_lag]\ntau_s = 200\n");
  const auto j = identify_json(args);
  CHECK(j["verdict"] == "thermal_lag");
  nlohmann::json a;
  for (const auto& alternative : j["alternatives"]) {
    if (alternative["other"] == "ambient_sensitivity") a = alternative;
  }
  REQUIRE(a.is_object());
  CHECK(a["effect"] == "thermal_lag");
  CHECK(a["told_apart"] == true);
  CHECK(a["correlation"].get<double>() > 0.9);
  CHECK(a["experiment"].get<std::string>().find("TEC steps with the chamber held") != std::string::npos);
  // The text names it on a line of its own.
  CHECK(run_identify(args).find("alternative: thermal_lag, not ambient_sensitivity (fitted contributions correlate") !=
        std::string::npos);
  fs::remove_all(dir);
}

