#pragma once

#include <array>

// The gyro's temperature characteristics as the seed measured them, as smooth
// functions of the die temperature for the plant model.
namespace gyrotc::model {

// Seed Table 2: uncompensated zero-rate output (mV), -40..80 C in 5 C steps.
inline constexpr double kTable2FirstC = -40.0;
inline constexpr double kTable2StepC = 5.0;
inline constexpr std::array<double, 25> kTable2GyroMv = {
    98.1, 105.9, 107.5, 108.2, 109.1, 108.9, 105.7, 103.5, 102.7, 98.4, 94.2, 88.3, 85.8,
    79.9, 74.4,  68.4,  60.6,  54.5,  51.6,  50.3,  52.4,  53.5,  53.2, 52.2, 52.7};

// Zero-rate output (mV) at temp_c: the natural cubic spline through Table 2
// (C2-smooth, passes through every measured point); outside -40..80 C it
// continues along the end tangents. No allocation.
double table2_bias_mv(double temp_c) noexcept;

// Seed Table 1: drive-mode resonant frequency (Hz) and quality factor, linear
// between the measured points (-40..60 C, 10 C steps), held at the ends.
double table1_drive_frequency_hz(double temp_c) noexcept;
double table1_drive_q(double temp_c) noexcept;

}  // namespace gyrotc::model
