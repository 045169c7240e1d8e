#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "gyrotc/algorithms/fit/bp_network_fit.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/app/formats/calibration_file.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"
#include "input_error_of.hpp"

using gyrotc::app::Calibration;
using gyrotc::app::InputError;
using gyrotc::app::parse_calibration;
using namespace gyrotc::fit;

namespace {

struct Table2 {
  std::vector<double> temp_c;
  std::vector<double> gyro_mv;
};

Table2 table2() {
  const auto t = gyrotc::app::CsvTable::read(gyrotc::test::data_file("table2_zero_bias.csv"));
  return {t.numbers("temp_c"), t.numbers("gyro_mv")};
}

// Writes the model, reads it back and compares the curves bit for bit.
void check_round_trip(const BiasModel& model) {
  const std::string text = gyrotc::app::format_calibration(model, 8.5);
  const Calibration back = parse_calibration(text, "round_trip.toml");
  CHECK(back.model.kind() == model.kind());
  CHECK(back.scale_mv_per_dps == 8.5);
  CHECK(back.model.t_min_c() == model.t_min_c());
  CHECK(back.model.t_max_c() == model.t_max_c());
  for (double t = -50.0; t <= 90.0; t += 0.37) CHECK(back.model.bias_mv(t) == model.bias_mv(t));
}

std::string with_header(const std::string& body) {
  return "format = \"gyrotc-calibration\"\nversion = 1\n" + body;
}

}  // namespace

TEST_CASE("polynomial, piecewise, spline, BP network and the paper reference survive a save and load") {
  const Table2 t = table2();
  MethodOptions o;
  o.method = Method::polynomial;
  o.orders = {6};
  check_round_trip(fit_method(t.temp_c, t.gyro_mv, o).model);
  o.method = Method::paper;
  o.orders.clear();
  check_round_trip(fit_method(t.temp_c, t.gyro_mv, o).model);
  o.method = Method::smoothing;
  check_round_trip(fit_method(t.temp_c, t.gyro_mv, o).model);
  BpTrainOptions bp;
  bp.hidden = {4, 3};
  bp.restarts = 1;
  bp.max_epochs = 5;
  check_round_trip(BiasModel::bp_network(train_bp_network(t.temp_c, t.gyro_mv, bp).net));
  check_round_trip(BiasModel::paper_reference());
}

TEST_CASE("save_calibration writes a file load_calibration reads") {
  const auto path = std::filesystem::path(gyrotc::test::scratch_dir()) / "calibration_test.toml";
  gyrotc::app::save_calibration(BiasModel::paper_reference(), path.string());
  const BiasModel back = gyrotc::app::load_calibration(path.string());
  CHECK(back.kind() == BiasModel::Kind::paper_reference);
  std::filesystem::remove(path);
  CHECK_THROWS_AS(gyrotc::app::load_calibration(path.string()), InputError);
}

TEST_CASE("the shipped default calibration is what fit --method auto makes of Table 2") {
  const BiasModel m = gyrotc::app::load_calibration(gyrotc::test::data_file("calibration_table2.toml"));
  const Table2 t = table2();
  MethodOptions o;
  o.method = Method::automatic;
  const MethodFit best = fit_method(t.temp_c, t.gyro_mv, o);
  CHECK(m.kind() == best.model.kind());
  for (double x = -40.0; x <= 80.0; x += 0.5) CHECK(m.bias_mv(x) == Approx(best.model.bias_mv(x)).margin(1e-9));
}

TEST_CASE("a calibration of the die keeps its lag through a save and load, and a file without one has none") {
  Polynomial p;
  p.coefficients_mv = {80.0, -0.5};
  p.t_min_c = -10.0;
  p.t_max_c = 70.0;
  const std::string text = gyrotc::app::format_calibration(BiasModel::polynomial(p), 8.774, {}, 42.25);
  CHECK(parse_calibration(text, "die.toml").die_lag_s == 42.25);
  CHECK(parse_calibration(gyrotc::app::format_calibration(BiasModel::polynomial(p), 8.774), "sensor.toml").die_lag_s ==
        0.0);
}

TEST_CASE("a die lag that is negative or over an hour is refused, naming the line") {
  auto error_of = [](const std::string& lag) {
    return gyrotc::test::input_error_of([&] {
      parse_calibration(with_header("kind = \"paper_reference\"\ndie_lag_s = " + lag + "\n"), "cal.toml");
    });
  };
  CHECK_THAT(error_of("-1"), Catch::Contains("cal.toml:4: key 'die_lag_s': must be 0..3600 s"));
  CHECK_THAT(error_of("42000"), Catch::Contains("cal.toml:4: key 'die_lag_s'"));
  CHECK_THAT(error_of("\"40\""), Catch::Contains("key 'die_lag_s': expected a number"));
  CHECK(parse_calibration(with_header("kind = \"paper_reference\"\ndie_lag_s = 3600\n"), "cal.toml").die_lag_s == 3600.0);
}

TEST_CASE("calibration errors name the file, line and key") {
  auto error_of = [](const std::string& text) {
    return gyrotc::test::input_error_of([&] { parse_calibration(text, "cal.toml"); });
  };
  CHECK_THAT(error_of("version = 1\nkind = \"paper_reference\"\n"), Catch::Contains("key 'format': missing"));
  CHECK_THAT(error_of(with_header("kind = \"quadric\"\n")), Catch::Contains("cal.toml:3: key 'kind'"));
  CHECK_THAT(error_of(with_header("kind = \"spline\"\nrange_c = [0.0, 10.0]\n[spline]\nknots_c = [0.0, 5.0, 5.0]\n"
                                  "values_mv = [1.0, 2.0, 3.0]\nsecond_derivatives = [0.0, 0.0, 0.0]\n")),
             Catch::Contains("cal.toml:6: key 'spline.knots_c[2]'"));
  CHECK_THAT(error_of(with_header("kind = \"spline\"\nrange_c = [0.0, 10.0]\n[spline]\nknots_c = [0.0, 5.0, 12.0]\n"
                                  "values_mv = [1.0, 2.0, 3.0]\nsecond_derivatives = [0.0, 0.0, 0.0]\n")),
             Catch::Contains("key 'spline.knots_c[2]': knots must ascend strictly inside range_c"));
  CHECK_THAT(error_of(with_header("kind = \"spline\"\nrange_c = [0.0, 10.0]\n[spline]\nknots_c = [0.0, 5.0, 10.0]\n"
                                  "values_mv = [1.0, 2.0]\nsecond_derivatives = [0.0, 0.0, 0.0]\n")),
             Catch::Contains("cal.toml:7: key 'spline.values_mv': need one value per knot (3), got 2"));
  CHECK_THAT(error_of(with_header("kind = \"polynomial\"\nrange_c = [0.0, 10.0]\n[polynomial]\ncenter_c = 0\n"
                                  "scale_c = 1\ncoefficients_mv = [1.0, \"x\"]\n")),
             Catch::Contains("key 'polynomial.coefficients_mv[1]': expected a number"));
  CHECK_THAT(error_of(with_header("kind = \"polynomial\"\nrange_c = [0.0, 10.0]\n[polynomial]\ncenter_c = 0\n"
                                  "scale_c = 1\ncoefficients_mv = [1.0]\ncolour = 2\n")),
             Catch::Contains("key 'polynomial.colour': unknown key"));
  CHECK_THAT(error_of(with_header("kind = \"polynomial\"\nrange_c = [10.0, 0.0]\n")),
             Catch::Contains("key 'range_c'"));
  CHECK_THAT(error_of(with_header("kind = \"piecewise\"\nrange_c = [0.0, 10.0]\n[piecewise]\n"
                                  "breakpoints_c = [5.0, 6.0]\n[[piecewise.segment]]\ncenter_c = 0\nscale_c = 1\n"
                                  "coefficients_mv = [1.0]\n[[piecewise.segment]]\ncenter_c = 0\nscale_c = 1\n"
                                  "coefficients_mv = [1.0]\n")),
             Catch::Contains("key 'piecewise.segment'"));
  CHECK_THAT(error_of(with_header("kind = \"bp_network\"\nrange_c = [0.0, 10.0]\n[bp_network]\n"
                                  "out_center_mv = 0\nout_half_range_mv = 1\n[[bp_network.layer]]\ninputs = 1\n"
                                  "outputs = 2\nactivation = \"tansig\"\nweights = [1.0]\nbiases = [0.0, 0.0]\n"
                                  "[[bp_network.layer]]\ninputs = 2\noutputs = 1\nactivation = \"linear\"\n"
                                  "weights = [1.0, 1.0]\nbiases = [0.0]\n")),
             Catch::Contains("layers[0].weights"));
  CHECK_THAT(error_of(with_header("kind = [\n")), Catch::Contains("cal.toml:3:"));
}

TEST_CASE("a calibration's error bound survives a save and load, and a file without one has none") {
  Polynomial p;
  p.coefficients_mv = {80.0, -0.5};
  p.t_min_c = 8.0;
  p.t_max_c = 67.0;
  gyrotc::app::CalibrationErrorBound bound;
  bound.range_dps = 0.0091;
  bound.temp_c = {8.0, 37.5, 67.0};
  bound.dps = {0.008, 0.004, 0.007};
  bound.how = "bootstrap";
  const gyrotc::app::Calibration c =
      parse_calibration(gyrotc::app::format_calibration(BiasModel::polynomial(p), 8.774, {}, 40.0, bound), "b.toml");
  REQUIRE(c.bound);
  CHECK(c.bound->confidence == 0.95);
  CHECK(c.bound->range_dps == 0.0091);
  CHECK(c.bound->temp_c == bound.temp_c);
  CHECK(c.bound->dps == bound.dps);
  CHECK(c.bound->how == "bootstrap");
  CHECK_FALSE(parse_calibration(gyrotc::app::format_calibration(BiasModel::polynomial(p), 8.774), "n.toml").bound);
}

TEST_CASE("a bound whose table is out of order, uneven or negative is refused, naming the key") {
  auto error_of = [](const std::string& bound) {
    return gyrotc::test::input_error_of([&] {
      parse_calibration(with_header("kind = \"paper_reference\"\n[bound]\nconfidence = 0.95\nrange_dps = 0.01\n" + bound),
                        "cal.toml");
    });
  };
  CHECK_THAT(error_of("c = [10.0, 5.0]\ndps = [0.01, 0.01]\n"), Catch::Contains("key 'bound.c': must be ascending"));
  CHECK_THAT(error_of("c = [5.0, 10.0]\ndps = [0.01]\n"),
             Catch::Contains("key 'bound.dps': needs one value per temperature of c (2)"));
  CHECK_THAT(error_of("c = [5.0, 10.0]\ndps = [0.01, -0.01]\n"), Catch::Contains("key 'bound.dps': must be 0 or more"));
  CHECK_THAT(error_of("c = [5.0, 10.0]\n"), Catch::Contains("key 'bound.dps': missing"));
  CHECK_THAT(error_of("c = [5.0, 10.0]\ndps = [0.01, 0.01]\nspread = 2\n"), Catch::Contains("key 'bound.spread': unknown key"));
}
