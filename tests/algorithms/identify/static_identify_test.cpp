#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "gyrotc/algorithms/identify/static_identify.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using gyrotc::identify::identify_static;
using gyrotc::identify::StaticQuantity;

namespace {

// Seed Table 1 (data/table1_resonance_q.csv): temp_c, drive_freq_hz,
// drive_q, sense_freq_hz, sense_q. Read here with plain streams: the
// algorithms tests link no CSV reader.
struct Table1 {
  std::vector<double> temp_c, drive_freq_hz, drive_q, sense_freq_hz, sense_q;
};

Table1 read_table1() {
  std::ifstream in(gyrotc::test::data_file("table1_resonance_q.csv"));
  REQUIRE(in.good());
  std::string line;
  std::getline(in, line);
  Table1 t;
  while (std::getline(in, line)) {
    std::array<double, 5> v{};
    std::stringstream row(line);
    std::string cell;
    for (double& x : v) {
      std::getline(row, cell, ',');
      x = std::stod(cell);
    }
    t.temp_c.push_back(v[0]);
    t.drive_freq_hz.push_back(v[1]);
    t.drive_q.push_back(v[2]);
    t.sense_freq_hz.push_back(v[3]);
    t.sense_q.push_back(v[4]);
  }
  REQUIRE(t.temp_c.size() == 11);
  return t;
}

}  // namespace

TEST_CASE("drive Q of Table 1 is explained by gas desorption, shrinking the log residual 5x") {
  const Table1 t = read_table1();
  const auto id = identify_static(t.temp_c, t.drive_q, StaticQuantity::quality_factor, "drive_q");
  CHECK(id.verdict == "gas_desorption");
  CHECK(id.baseline_rms > 0.2);  // Eq. 10 alone leaves tens of percent
  CHECK(id.shrink >= 5.0);
  REQUIRE(id.added.size() == 1);
  CHECK(id.added[0].delta_bic > 10.0);
}

TEST_CASE("sense Q of Table 1 is explained by gas desorption, shrinking the log residual 5x") {
  const Table1 t = read_table1();
  const auto id = identify_static(t.temp_c, t.sense_q, StaticQuantity::quality_factor, "sense_q");
  CHECK(id.verdict == "gas_desorption");
  CHECK(id.shrink >= 5.0);
}

TEST_CASE("drive frequency of Table 1 needs no effect beyond a linear coefficient near -30 ppm/K") {
  const Table1 t = read_table1();
  const auto id =
      identify_static(t.temp_c, t.drive_freq_hz, StaticQuantity::frequency_hz, "drive_freq_hz");
  CHECK(id.verdict == "none");
  REQUIRE(id.baseline_params.size() == 1);
  CHECK(id.baseline_params[0].value == Approx(-30.0).margin(3.0));
}

TEST_CASE("a quality factor that follows Eq. 10 exactly (plus noise) needs no effect") {
  const Table1 t = read_table1();
  std::vector<double> q;
  for (std::size_t i = 0; i < t.temp_c.size(); ++i) {
    const double noise = 0.01 * std::sin(7.3 * static_cast<double>(i));  // 1 % scatter
    q.push_back(12000.0 * std::sqrt(293.15 / (t.temp_c[i] + 273.15)) * (1.0 + noise));
  }
  const auto id = identify_static(t.temp_c, q, StaticQuantity::quality_factor, "drive_q");
  CHECK(id.verdict == "none");
}

TEST_CASE("a frequency with a strong quadratic coefficient is named quadratic_tc") {
  const Table1 t = read_table1();
  std::vector<double> f;
  for (std::size_t i = 0; i < t.temp_c.size(); ++i) {
    const double dt = t.temp_c[i] - 10.0;
    const double noise = 0.02 * std::sin(5.1 * static_cast<double>(i));
    f.push_back(2472.0 * (1.0 - 30e-6 * dt - 0.5e-6 * dt * dt) + noise);
  }
  const auto id = identify_static(t.temp_c, f, StaticQuantity::frequency_hz, "drive_freq_hz");
  CHECK(id.verdict == "quadratic_tc");
  REQUIRE(id.added.size() == 1);
  CHECK(id.added[0].params[0].value == Approx(-0.5).margin(0.1));
}
