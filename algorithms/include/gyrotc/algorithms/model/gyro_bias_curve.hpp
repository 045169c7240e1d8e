#pragma once

#include <array>
#include <vector>

// The gyro's temperature characteristics as the seed measured them, as smooth
// functions of the die temperature for the plant model.
namespace gyrotc::model {

// Seed Table 2: uncompensated zero-rate output (mV), -40..80 C in 5 C steps.
inline constexpr double kTable2FirstC = -40.0;
inline constexpr double kTable2StepC = 5.0;
inline constexpr std::array<double, 25> kTable2GyroMv = {
    98.1, 105.9, 107.5, 108.2, 109.1, 108.9, 105.7, 103.5, 102.7, 98.4, 94.2, 88.3, 85.8,
    79.9, 74.4,  68.4,  60.6,  54.5,  51.6,  50.3,  52.4,  53.5,  53.2, 52.2, 52.7};

// A gyro's zero-rate output (mV) against its die temperature: the natural
// cubic spline through measured points (C2-smooth, through every point),
// continued along the end tangents outside them. The plant's gyro has one
// (PlantParams::zero_bias), so that calibration is tested on curves other
// than the one the shipped calibration was fitted to.
class ZeroBiasCurve {
 public:
  ZeroBiasCurve();  // seed Table 2
  // Throws std::invalid_argument when the lists differ in length, hold fewer
  // than 2 points or a non-finite number, or the temperatures do not rise.
  ZeroBiasCurve(std::vector<double> temp_c, std::vector<double> gyro_mv);

  // No allocation. A non-finite temperature gives the first point's value.
  double bias_mv(double temp_c) const noexcept;

  const std::vector<double>& temp_c() const noexcept { return temp_c_; }
  const std::vector<double>& gyro_mv() const noexcept { return gyro_mv_; }
  bool operator==(const ZeroBiasCurve& other) const = default;

 private:
  double slope(std::size_t segment, double offset_c) const noexcept;

  std::vector<double> temp_c_;
  std::vector<double> gyro_mv_;
  std::vector<double> second_derivatives_;
};

// Zero-rate output (mV) at temp_c of the seed's part: ZeroBiasCurve() (Table 2).
double table2_bias_mv(double temp_c) noexcept;

// Seed Table 1: drive-mode resonant frequency (Hz) and quality factor, linear
// between the measured points (-40..60 C, 10 C steps), held at the ends.
double table1_drive_frequency_hz(double temp_c) noexcept;
double table1_drive_q(double temp_c) noexcept;

}  // namespace gyrotc::model
