#pragma once
// Reads the seed's Table 2 (data/table2_zero_bias.csv) for the fit tests.

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "test_paths.hpp"

namespace gyrotc::test {

struct Table2 {
  std::vector<double> temp_c;
  std::vector<double> gyro_mv;
  std::vector<double> bias_dps;
};

inline Table2 read_table2() {
  std::ifstream in(gyrotc::test::data_file("table2_zero_bias.csv"));
  if (!in) throw std::runtime_error("cannot open table2_zero_bias.csv");
  Table2 t;
  std::string line;
  std::getline(in, line);  // header: temp_c,gyro_mv,bias_dps
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::istringstream row(line);
    std::string cell;
    std::getline(row, cell, ',');
    t.temp_c.push_back(std::stod(cell));
    std::getline(row, cell, ',');
    t.gyro_mv.push_back(std::stod(cell));
    std::getline(row, cell, ',');
    t.bias_dps.push_back(std::stod(cell));
  }
  return t;
}

}  // namespace gyrotc::test
