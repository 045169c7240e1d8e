#include <nlohmann/json.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
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

TEST_CASE("fit --method spline --json reports the plain spline's LOO, which SciPy gives as 0.424 / 0.138") {
  // Issue 20's figure, computed with scipy.interpolate.CubicSpline: an
  // independent check of the command's LOO; nothing is chosen, so the
  // nested figure is the same.
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "spline", "--json"}));
  CHECK(j["fitted"] == "spline");
  CHECK(j["points"] == 25);
  CHECK(j["loo_max_abs_dps"].get<double>() == Approx(0.424).margin(0.0005));
  CHECK(j["loo_rms_dps"].get<double>() == Approx(0.138).margin(0.0005));
  CHECK(j["nested_loo_max_abs_dps"].get<double>() == j["loo_max_abs_dps"].get<double>());
  CHECK(j["in_sample_max_abs_dps"].get<double>() < 1e-9);
  CHECK(j["model"]["kind"] == "spline");
}

TEST_CASE("fit --method auto --nested --json meets issue 20 on Table 2 and has no step") {
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "auto", "--nested", "--json"}));
  CHECK(j["nested_loo_max_abs_dps"].get<double>() <= 0.42);
  CHECK(j["nested_loo_rms_dps"].get<double>() <= 0.14);
  CHECK(j["largest_breakpoint_step_mv"].get<double>() < 0.1);
  REQUIRE(j["candidates"].is_array());
  int chosen = 0;
  for (const auto& c : j["candidates"]) chosen += c["chosen"].get<bool>() ? 1 : 0;
  CHECK(chosen == 1);
}

TEST_CASE("fit --no-nested leaves the nested figures out") {
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "poly", "--no-nested", "--json"}));
  CHECK_FALSE(j.contains("nested_loo_max_abs_dps"));
  CHECK(j.contains("loo_max_abs_dps"));
}

TEST_CASE("fit --out of a piecewise model writes joined segments unless --continuity none") {
  const fs::path out = fs::temp_directory_path() / (std::to_string(::getpid()) + "_joined.toml");
  auto largest_step = [&] {
    const auto m = gyrotc::app::load_calibration(out.string());
    const auto& pw = *m.as_piecewise();
    double worst = 0.0;
    for (std::size_t i = 0; i < pw.breakpoints_c.size(); ++i) {
      const double b = pw.breakpoints_c[i];
      worst = std::max(worst, std::fabs(gyrotc::fit::evaluate(pw.segments[i + 1], b) -
                                        gyrotc::fit::evaluate(pw.segments[i], b)));
    }
    return worst;
  };
  run_fit({"--data", kTable2, "--method", "piecewise", "--breakpoints", "-7.5,52.5", "--no-nested", "--out",
           out.string()});
  CHECK(largest_step() < 0.1);
  run_fit({"--data", kTable2, "--method", "piecewise", "--breakpoints", "-20,50", "--order", "4,3,4",
           "--continuity", "none", "--out", out.string()});
  CHECK(largest_step() > 0.1);
  fs::remove(out);
}

TEST_CASE("fit text output names the method and the error figures") {
  const std::string out = run_fit({"--data", kTable2, "--method", "poly", "--order", "3"});
  for (const char* key : {"method: poly", "points: 25", "nested_loo_max_abs_dps:", "in_sample_max_abs_dps:",
                          "in_sample_rms_dps:", "loo_max_abs_dps:", "loo_rms_dps:", "condition_number:",
                          "model: polynomial"}) {
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
  for (int i = 0; i < 300; ++i) {
    const double t = -10.0 + 0.1 * i;  // -10 .. 19.9 C at 0.1 C/min
    csv += std::to_string(60 * i) + "," + std::to_string(t) + "," + std::to_string(100.0 - 0.5 * t) + "\n";
  }
  const fs::path p = write_temp("series.csv", csv);
  const auto j = nlohmann::json::parse(
      run_fit({"--data", p.string(), "--method", "poly", "--order", "1", "--bin-width", "2", "--json"}));
  CHECK(j["points"] == 15);
  CHECK(j["in_sample_max_abs_dps"].get<double>() < 1e-6);
  fs::remove(p);
}

namespace {

// A board record (kRecordCsvHeader) of `seconds` at 1 Hz: the casing as
// temp(t), the TEC on and the setpoint at `setpoint_c` when `held`.
std::string board_record(int seconds, double (*temp)(double), bool held, double setpoint_c = 55.0) {
  std::string csv = "time_s,sensor_c,ambient_c,gyro_mv,rate_dps_compensated,tec_a,setpoint_c,flags\n";
  for (int i = 0; i < seconds; ++i) {
    const double t = temp(i);
    csv += std::to_string(i) + "," + std::to_string(t) + ",16," + std::to_string(100.0 - 0.5 * t + 0.002 * t * t) +
           ",0," + (held ? "0.8," : "0,") + std::to_string(setpoint_c) + "," + (held ? "0" : "256") + "\n";
  }
  return csv;
}

double slow_sweep(double s) { return -20.0 + 60.0 * s / 36000.0; }          // -20 .. 40 C in 10 h: 0.1 C/min
double warm_up_then_hold(double s) { return s < 600.0 ? 16.0 + 39.0 * s / 600.0 : 55.0; }  // 3.9 C/min, then held
double fast_sweep(double s) { return -20.0 + 60.0 * s / 3600.0; }          // 1 C/min
double narrow_sweep(double s) { return 20.0 + 10.0 * s / 36000.0; }        // 10 C

}  // namespace

TEST_CASE("fit refuses a record the TEC held at its setpoint, says why and what to record, and writes nothing") {
  const fs::path p = write_temp("closed_loop.csv", board_record(7200, warm_up_then_hold, true));
  const fs::path out = fs::temp_directory_path() / (std::to_string(::getpid()) + "_closed_loop.toml");
  const std::string e = error_of({"--data", p.string(), "--out", out.string()});
  CHECK_THAT(e, Catch::Contains("closed_loop.csv: cannot calibrate (held): the TEC held the casing within 0.5 C of "
                                "the setpoint 55 C for 92 % of the record"));
  CHECK_THAT(e, Catch::Contains("gyrotc record --pid off"));
  CHECK_FALSE(fs::exists(out));
  // No flag overrides it: the other temperatures were passed on the way.
  CHECK_THAT(error_of({"--data", p.string(), "--accept", "span,uneven,unsettled"}), Catch::Contains("(held)"));
  fs::remove(p);
}

TEST_CASE("a board record's flags must be a flag word: a bad one is refused naming the line") {
  std::string csv = board_record(36000, slow_sweep, false);
  csv += "36000,40,16,90,0,0,55,-3\n";
  const fs::path p = write_temp("bad_flags.csv", csv);
  CHECK_THAT(error_of({"--data", p.string()}), Catch::Contains("bad_flags.csv:36002: flags must be"));
  fs::remove(p);
}

TEST_CASE("fit fits the same slow sweep the TEC did not hold") {
  const fs::path p = write_temp("open_loop.csv", board_record(36000, slow_sweep, false));
  const auto j = nlohmann::json::parse(run_fit({"--data", p.string(), "--method", "poly", "--order", "2", "--json"}));
  CHECK(j["points"] == 60);
  CHECK(j["in_sample_max_abs_dps"].get<double>() < 0.01);
  fs::remove(p);
}

namespace {

// The gyro reads a line at the die, which lags the sensor by 600 s: on the
// slow sweep's 0.1 C/min ramp it sits 1 C behind.
std::string lagging_die_record() {
  std::string csv = "time_s,sensor_c,gyro_mv\n";
  double die_c = slow_sweep(0.0);
  for (int i = 0; i < 36000; ++i) {
    const double sensor_c = slow_sweep(i);
    die_c += (sensor_c - die_c) * (1.0 - std::exp(-1.0 / 600.0));
    csv += std::to_string(i) + "," + std::to_string(sensor_c) + "," + std::to_string(100.0 - 0.5 * die_c) + "\n";
  }
  return csv;
}

}  // namespace

TEST_CASE("fit --die-lag-s bins a recording by the die's temperature, where the sensor's bins are a degree off") {
  const fs::path p = write_temp("lagging_die.csv", lagging_die_record());
  const fs::path by_die = fs::temp_directory_path() / (std::to_string(::getpid()) + "_by_die.toml");
  const fs::path by_sensor = fs::temp_directory_path() / (std::to_string(::getpid()) + "_by_sensor.toml");
  run_fit({"--data", p.string(), "--method", "poly", "--order", "1", "--die-lag-s", "600", "--out", by_die.string()});
  run_fit({"--data", p.string(), "--method", "poly", "--order", "1", "--out", by_sensor.string()});
  // The line is 100 mV at 0 C; binned by the sensor it is read 1 C late (0.5 mV).
  CHECK(gyrotc::app::load_calibration(by_die.string()).bias_mv(0.0) == Approx(100.0).margin(0.02));
  CHECK(gyrotc::app::load_calibration(by_sensor.string()).bias_mv(0.0) == Approx(100.5).margin(0.05));
  const auto j = nlohmann::json::parse(
      run_fit({"--data", p.string(), "--method", "poly", "--order", "1", "--die-lag-s", "600", "--json"}));
  CHECK(j["die_lag_s"] == 600.0);
  CHECK_THAT(j["input"].get<std::string>(), Catch::Contains("bins of the die (the sensor through a 600.0 s lag)"));
  fs::remove(p);
  fs::remove(by_die);
  fs::remove(by_sensor);
}

TEST_CASE("fit --die-lag-s is refused on a table, which has no time to lag over, and when negative") {
  CHECK_THAT(error_of({"--data", kTable2, "--die-lag-s", "60"}), Catch::Contains("--die-lag-s: a table"));
  CHECK_THAT(error_of({"--data", kTable2, "--die-lag-s", "-1"}), Catch::Contains("--die-lag-s: must be 0 or more"));
}

TEST_CASE("a recording's bins are held out two bin widths each side by default, a table's one by one") {
  const fs::path p = write_temp("blocks.csv", board_record(36000, slow_sweep, false));
  const auto series = nlohmann::json::parse(run_fit({"--data", p.string(), "--no-nested", "--json"}));
  CHECK(series["cv_block_c"].get<double>() == 2.0);
  CHECK_THAT(series["choice"].get<std::string>(), Catch::Contains("within 2 C of it"));
  const auto wide = nlohmann::json::parse(run_fit({"--data", p.string(), "--bin-width", "2", "--no-nested", "--json"}));
  CHECK(wide["cv_block_c"].get<double>() == 4.0);
  const auto plain = nlohmann::json::parse(run_fit({"--data", p.string(), "--cv-block", "0", "--no-nested", "--json"}));
  CHECK(plain["cv_block_c"].get<double>() == 0.0);
  CHECK_THAT(plain["choice"].get<std::string>(), Catch::Contains("by leave-one-out"));
  const auto table = nlohmann::json::parse(run_fit({"--data", kTable2, "--no-nested", "--json"}));
  CHECK(table["cv_block_c"].get<double>() == 0.0);
  CHECK_THAT(error_of({"--data", kTable2, "--cv-block", "-1"}), Catch::Contains("--cv-block"));
  CHECK_THAT(error_of({"--data", kTable2, "--cv-block", "31"}),
             Catch::Contains("--cv-block 31: wider than a quarter of the data's 120.0 C range (at most 30.0 C)"));
  fs::remove(p);
}

TEST_CASE("fit --compare lists a method the data cannot take with its reason, and compares the others") {
  // 0 .. 60 C: the seed's breakpoint at -20 C lies outside the record.
  const fs::path p = write_temp("compare_sweep.csv",
                                board_record(36000, [](double s) { return 60.0 * s / 36000.0; }, false));
  const auto j = nlohmann::json::parse(run_fit({"--data", p.string(), "--compare", "--no-nested", "--json"}));
  bool paper_listed = false;
  int compared = 0;
  for (const auto& m : j["methods"]) {
    if (m["method"] == "paper") {
      paper_listed = true;
      CHECK_THAT(m["structure"].get<std::string>(), Catch::Contains("not fitted: paper: piecewise: breakpoint -20"));
      CHECK(m["dof"].is_null());
    } else if (!m["loo_rms_dps"].is_null()) {
      ++compared;
    }
  }
  CHECK(paper_listed);
  CHECK(compared == 6);  // poly, piecewise, spline, smooth, bpnn, auto
  fs::remove(p);
}

TEST_CASE("fit --compare fails when no method could be fitted, naming the first reason") {
  const fs::path p = write_temp("two_points.csv", "temp_c,gyro_mv\n10,80\n20,81\n");
  CHECK_THAT(error_of({"--data", p.string(), "--compare", "--no-nested"}),
             Catch::Contains("two_points.csv: no method could be fitted; the first: paper: need at least 3 points"));
  fs::remove(p);
}

TEST_CASE("fit refuses a sweep too fast for the die to follow, and --accept unsettled fits it and says so in [source]") {
  const fs::path p = write_temp("fast.csv", board_record(3600, fast_sweep, false));
  CHECK_THAT(error_of({"--data", p.string()}),
             Catch::Contains("cannot calibrate (unsettled): in 60 of 60 bins the casing moved faster than 0.5 C/min"));
  const fs::path out = fs::temp_directory_path() / (std::to_string(::getpid()) + "_fast.toml");
  run_fit({"--data", p.string(), "--method", "poly", "--order", "2", "--accept", "unsettled", "--out", out.string()});
  std::ifstream in(out);
  const std::string toml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK_THAT(toml, Catch::Contains("accepted = [\"unsettled: in 60 of 60 bins"));
  fs::remove(p);
  fs::remove(out);
}

TEST_CASE("fit refuses a record that spans too little temperature for the model asked for") {
  const fs::path p = write_temp("narrow.csv", board_record(36000, narrow_sweep, false));
  CHECK_THAT(error_of({"--data", p.string()}),
             Catch::Contains("cannot calibrate (span): the casing spans 20.0 .. 30.0 C in 10 bins of 1 C"));
  const fs::path wide = write_temp("wide.csv", board_record(36000, slow_sweep, false));
  // 60 bins are enough for a cubic, not for an order 20 polynomial (3 per coefficient).
  CHECK_THAT(error_of({"--data", wide.string(), "--method", "poly", "--order", "20"}),
             Catch::Contains("needs at least 20 C and 63 bins"));
  fs::remove(p);
  fs::remove(wide);
}

TEST_CASE("fit refuses a record whose bins hold wildly different numbers of samples") {
  // The slow sweep, then two hours held at 40.2 C: that bin holds 11.7x the median.
  std::string csv = board_record(36000, slow_sweep, false);
  for (int i = 36000; i < 36000 + 7000; ++i) {
    csv += std::to_string(i) + ",40.2,16,90,0,0,55,256\n";
  }
  const fs::path p = write_temp("uneven.csv", csv);
  CHECK_THAT(error_of({"--data", p.string()}), Catch::Contains("cannot calibrate (uneven): the 40 C bin holds"));
  CHECK_NOTHROW(run_fit({"--data", p.string(), "--method", "poly", "--order", "2", "--accept", "uneven", "--json"}));
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

TEST_CASE("unknown methods and option values are rejected naming the option") {
  CHECK_THAT(error_of({"--data", kTable2, "--method", "lagrange"}), Catch::Contains("--method"));
  CHECK_THAT(error_of({"--data", kTable2, "--method", "piecewise", "--continuity", "c2"}),
             Catch::Contains("--continuity"));
  CHECK_THAT(error_of({"--data", kTable2, "--method", "smooth", "--criterion", "aic"}), Catch::Contains("--criterion"));
  CHECK_THAT(error_of({"--data", kTable2, "--method", "smooth", "--dof", "40"}), Catch::Contains("dof"));
}

TEST_CASE("fit --plot writes the calibration report: every point, the model, and each point's held-out residual") {
  const fs::path svg = fs::temp_directory_path() / (std::to_string(::getpid()) + "_fit.svg");
  const std::string out = run_fit({"--data", kTable2, "--method", "poly", "--order", "5", "--plot", svg.string()});
  CHECK_THAT(out, Catch::Contains("wrote " + svg.string()));
  std::ifstream in(svg);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::size_t circles = 0;
  for (std::size_t at = text.find("<circle"); at != std::string::npos; at = text.find("<circle", at + 1)) ++circles;
  CHECK(circles == 25 + 25 + 2);  // the points, their residuals, and a dot in each legend entry
  CHECK_THAT(text, Catch::Contains("25 points of the table"));
  CHECK_THAT(text, Catch::Contains("held-out residual (deg/s)"));
  // A method that chooses nothing: the held-out residual is the plain LOO.
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "poly", "--order", "5", "--json"}));
  char expect[64];
  std::snprintf(expect, sizeof expect, "nested LOO max %.3f", j["loo_max_abs_dps"].get<double>());
  CHECK_THAT(text, Catch::Contains(expect));
  fs::remove(svg);
}

TEST_CASE("fit --plot is refused with --compare, which fits no one model") {
  CHECK_THAT(error_of({"--data", kTable2, "--compare", "--plot", "x.svg"}), Catch::Contains("--plot: not with --compare"));
}

TEST_CASE("fit states the calibration's own error bound: printed, in --json and in the file's [bound]") {
  const fs::path out = fs::temp_directory_path() / (std::to_string(::getpid()) + "_bound.toml");
  const auto j = nlohmann::json::parse(
      run_fit({"--data", kTable2, "--method", "poly", "--order", "4", "--json", "--out", out.string()}));
  REQUIRE(j["bound"].is_object());
  const double range_dps = j["bound"]["range_dps"].get<double>();
  CHECK(range_dps > 0.0);
  CHECK(j["bound"]["confidence"].get<double>() == 0.95);
  CHECK(j["bound"]["range_c"][0].get<double>() == -40.0);
  CHECK(j["bound"]["range_c"][1].get<double>() == 80.0);
  CHECK(j["bound"]["c"].size() == j["bound"]["dps"].size());
  const gyrotc::app::Calibration c = gyrotc::app::read_calibration(out.string());
  REQUIRE(c.bound);
  CHECK(c.bound->range_dps == Approx(range_dps).margin(1e-5));
  const std::string text = run_fit({"--data", kTable2, "--method", "poly", "--order", "4"});
  CHECK_THAT(text, Catch::Contains("bound: calibration error <= 0.") &&
                       Catch::Contains(" deg/s (95 %) over -40.0 .. 80.0 C; at one temperature "));
  fs::remove(out);
}

TEST_CASE("fit --no-bound writes no bound and says so, and too few refits are refused") {
  const auto j = nlohmann::json::parse(run_fit({"--data", kTable2, "--method", "poly", "--order", "4", "--json", "--no-bound"}));
  CHECK(j["bound"].is_null());
  CHECK_THAT(run_fit({"--data", kTable2, "--method", "poly", "--order", "4", "--no-bound"}),
             Catch::Contains("bound: none (--no-bound)"));
  CHECK_THAT(gyrotc::test::input_error_of([] { run_fit({"--data", kTable2, "--bound-replicates", "5"}); }),
             Catch::Contains("--bound-replicates: must be at least 20"));
}

TEST_CASE("a noisier recording gets a wider bound from fit") {
  auto record = [](double noise_mv) {
    std::string csv = "time_s,sensor_c,gyro_mv\n";
    std::uint64_t x = 12345;
    for (int i = 0; i < 7200; ++i) {  // 10 .. 60 C and back at 0.83 C/min, 1 Hz
      const double t = i < 3600 ? 10.0 + 50.0 * i / 3600.0 : 60.0 - 50.0 * (i - 3600) / 3600.0;
      x = x * 6364136223846793005ULL + 1442695040888963407ULL;
      const double u = static_cast<double>(x >> 11) * 0x1.0p-53 - 0.5;  // uniform, sd 0.29
      csv += std::to_string(i) + "," + std::to_string(t) + "," + std::to_string(100.0 - 0.5 * t + noise_mv * u) + "\n";
    }
    return csv;
  };
  auto bound_of = [&](double noise_mv, const char* name) {
    const fs::path p = write_temp(name, record(noise_mv));
    const auto j = nlohmann::json::parse(run_fit({"--data", p.string(), "--method", "poly", "--order", "2", "--json",
                                                 "--bound-replicates", "60"}));
    fs::remove(p);
    return j["bound"]["range_dps"].get<double>();
  };
  const double quiet = bound_of(0.2, "quiet.csv");
  const double loud = bound_of(2.0, "loud.csv");
  INFO(quiet << " and " << loud << " deg/s");
  CHECK(loud > 5.0 * quiet);
}
