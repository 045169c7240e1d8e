#include "gyrotc/app/formats/csv_table.hpp"

#include <cmath>
#include <string>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "input_error_of.hpp"

using gyrotc::app::CsvTable;

namespace {
std::string error_of(const std::string& text, const char* column = "gyro_mv") {
  return gyrotc::test::input_error_of([&] { CsvTable::parse(text, "in.csv").numbers(column); });
}
}  // namespace

TEST_CASE("numeric columns are read by name, skipping blank and comment lines") {
  const auto t = CsvTable::parse("# chamber run\ntemp_c,gyro_mv\n-40,98.1\n\n-35, 105.9\r\n", "in.csv");
  REQUIRE(t.rows() == 2);
  CHECK(t.numbers("temp_c") == std::vector<double>{-40.0, -35.0});
  CHECK(t.numbers("gyro_mv") == std::vector<double>{98.1, 105.9});
  CHECK(t.line_of(1) == 5);
}

TEST_CASE("a non-numeric cell is reported with file, line and column") {
  CHECK(error_of("temp_c,gyro_mv\n1,2\n3,abc\n") == "in.csv:3: column 'gyro_mv': 'abc' is not a number");
}

TEST_CASE("NaN and empty cells are rejected with their line") {
  CHECK(error_of("temp_c,gyro_mv\n1,nan\n") == "in.csv:2: column 'gyro_mv': 'nan' is not a finite number");
  CHECK(error_of("temp_c,gyro_mv\n1,\n") == "in.csv:2: column 'gyro_mv': empty cell");
}

TEST_CASE("numbers_or_nan reads a writer's 'nan' as NaN and still refuses text and infinities") {
  const auto t = CsvTable::parse("t,rate_dps\n1,nan\n2,0.5\n", "in.csv");
  const auto v = t.numbers_or_nan("rate_dps");
  REQUIRE(v.size() == 2);
  CHECK(std::isnan(v[0]));
  CHECK(v[1] == 0.5);
  CHECK(gyrotc::test::input_error_of([] { CsvTable::parse("t,x\n1,abc\n", "in.csv").numbers_or_nan("x"); }) ==
        "in.csv:2: column 'x': 'abc' is not a number");
  CHECK(gyrotc::test::input_error_of([] { CsvTable::parse("t,x\n1,inf\n", "in.csv").numbers_or_nan("x"); }) ==
        "in.csv:2: column 'x': 'inf' is not a finite number");
}

TEST_CASE("a missing column names the columns that are there") {
  CHECK(error_of("temp_c,bias_dps\n1,2\n") ==
        "in.csv: missing column 'gyro_mv' (columns: temp_c, bias_dps)");
}

TEST_CASE("a row with the wrong number of fields is reported") {
  CHECK_THROWS_WITH(CsvTable::parse("a,b\n1,2,3\n", "in.csv"), "in.csv:2: 3 fields, but the header has 2");
}

TEST_CASE("require_increasing names the first line that goes backwards") {
  const auto t = CsvTable::parse("time_s,x\n0,1\n1,1\n1,1\n", "in.csv");
  CHECK_THROWS_WITH(t.require_increasing("time_s"), "in.csv:4: column 'time_s' must increase (1 after 1)");
}

TEST_CASE("quoted text cells may hold commas") {
  const auto t = CsvTable::parse("segment,description\nA,\"hold, then ramp\"\n", "in.csv");
  CHECK(t.text("description") == std::vector<std::string>{"hold, then ramp"});
}

TEST_CASE("numbers take the forms CSV writers produce: sign, exponent, bare point") {
  const auto t = CsvTable::parse("x\n+1.5\n-2\n.5\n3.\n1e-3\n-4.25E+2\n", "in.csv");
  CHECK(t.numbers("x") == std::vector<double>{1.5, -2.0, 0.5, 3.0, 1e-3, -425.0});
}

TEST_CASE("a doubled sign, trailing text, an overflow and infinity are not numbers") {
  CHECK(error_of("gyro_mv\n+-1\n") == "in.csv:2: column 'gyro_mv': '+-1' is not a number");
  CHECK(error_of("gyro_mv\n+\n") == "in.csv:2: column 'gyro_mv': '+' is not a number");
  CHECK(error_of("gyro_mv\n1.5mV\n") == "in.csv:2: column 'gyro_mv': '1.5mV' is not a number");
  CHECK(error_of("gyro_mv\n1e999\n") == "in.csv:2: column 'gyro_mv': '1e999' is not a finite number");
  CHECK(error_of("gyro_mv\n-inf\n") == "in.csv:2: column 'gyro_mv': '-inf' is not a finite number");
}

TEST_CASE("a table keeps its cells when moved and copied") {
  // Short files sit in std::string's inline buffer: the cells must not point there.
  CsvTable moved = CsvTable::parse("x\n7\n", "in.csv");
  const CsvTable copy = moved;
  const CsvTable target = std::move(moved);
  CHECK(target.numbers("x") == std::vector<double>{7.0});
  CHECK(copy.numbers("x") == std::vector<double>{7.0});
}
