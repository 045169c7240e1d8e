#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "gyrotc/app/calibration_file.hpp"
#include "gyrotc/app/commands.hpp"
#include "gyrotc/app/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"
#include "run_command.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kTable2 = gyrotc::test::data_file("table2_zero_bias.csv");

std::string run_fit(const std::vector<std::string>& args) {
  return gyrotc::test::run_command(gyrotc::app::add_fit_command, "fit", args);
}

fs::path write_temp(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / (std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

std::string error_of(const std::vector<std::string>& args) {
  return gyrotc::test::input_error_of([&] { run_fit(args); });
}

}  // namespace

TEST_CASE("fit --method paper --json reports the seed segmentation's figures") {
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "paper", "--json"}));
  CHECK(j["method"] == "paper");
  CHECK(j["points"] == 25);
  CHECK(j["in_sample_max_abs_dps"].get<double>() == Approx(0.178).margin(0.002));
  CHECK(j["loo_max_abs_dps"].get<double>() == Approx(0.562).margin(0.002));
  CHECK(j.contains("in_sample_rms_dps"));
  CHECK(j.contains("loo_rms_dps"));
  CHECK(j["model"]["kind"] == "piecewise");
}

TEST_CASE("fit text output names the method and the error figures") {
  const std::string out = run_fit({"--data", kTable2, "--method", "poly", "--order", "3"});
  for (const char* key : {"method: poly", "points: 25", "in_sample_max_abs_dps:", "in_sample_rms_dps:",
                          "loo_max_abs_dps:", "loo_rms_dps:", "condition_number:", "model: polynomial"}) {
    CHECK_THAT(out, Catch::Contains(key));
  }
}

TEST_CASE("fit --out writes a calibration the controller can load") {
  const fs::path out = fs::temp_directory_path() / (std::to_string(::getpid()) + "_cal.toml");
  run_fit({"--data", kTable2, "--method", "piecewise", "--breakpoints", "-20,50", "--order", "4,3,4", "--out",
           out.string()});
  const auto m = gyrotc::app::load_calibration(out.string());
  CHECK(m.kind() == gyrotc::fit::BiasModel::Kind::piecewise);
  CHECK(m.bias_mv(-40.0) == Approx(98.1).margin(0.5));
  fs::remove(out);
}

TEST_CASE("a time series is averaged in temperature bins") {
  std::string csv = "time_s,sensor_c,gyro_mv\n";
  for (int i = 0; i < 200; ++i) {
    const double t = -10.0 + 0.1 * i;  // -10 .. 9.9 C
    csv += std::to_string(i) + "," + std::to_string(t) + "," + std::to_string(100.0 - 0.5 * t) + "\n";
  }
  const fs::path p = write_temp("series.csv", csv);
  const auto j = nlohmann::json::parse(
      run_fit({"--data", p.string(), "--method", "poly", "--order", "1", "--bin-width", "2", "--json"}));
  CHECK(j["points"] == 10);
  CHECK(j["in_sample_max_abs_dps"].get<double>() < 1e-6);
  fs::remove(p);
}

TEST_CASE("bad CSV input is rejected with the file and line") {
  const fs::path missing = write_temp("missing.csv", "temp_c,volts\n1,2\n");
  CHECK_THAT(error_of({"--data", missing.string()}), Catch::Contains("missing column 'gyro_mv'"));
  const fs::path word = write_temp("word.csv", "temp_c,gyro_mv\n1,2\n2,abc\n3,4\n");
  CHECK_THAT(error_of({"--data", word.string()}), Catch::Contains("word.csv:3:"));
  const fs::path nan = write_temp("nan.csv", "temp_c,gyro_mv\n1,2\n2,3\nnan,4\n");
  CHECK_THAT(error_of({"--data", nan.string()}), Catch::Contains("nan.csv:4:"));
  const fs::path dup = write_temp("dup.csv", "temp_c,gyro_mv\n1,2\n2,3\n3,4\n2,5\n");
  CHECK_THAT(error_of({"--data", dup.string()}), Catch::Contains("dup.csv:5: temp_c 2 repeats the temperature of line 3"));
  const fs::path few = write_temp("few.csv", "temp_c,gyro_mv\n1,2\n2,3\n3,4\n4,4\n");
  CHECK_THAT(error_of({"--data", few.string(), "--method", "poly", "--order", "4"}),
             Catch::Contains("needs at least 5 points"));
  for (const auto& p : {missing, word, nan, dup, few}) fs::remove(p);
}

TEST_CASE("an unknown method is rejected") {
  CHECK_THAT(error_of({"--data", kTable2, "--method", "spline"}), Catch::Contains("--method"));
}
