#pragma once

#include <span>
#include <string>

#include "gyrotc/algorithms/identify/identification.hpp"

// The workflow on static characteristics against temperature (seed Table 1).
//  - quality factor: baseline seed Eq. 10, Q = c * T^-1/2 (free-molecule gas
//    damping, fixed gas quantity, T in kelvin), residual in ln Q; candidates
//    gas_desorption (Q = c T^-1/2 / (1 + a exp(-Ea/(R T)))) and
//    parallel_loss (1/Q = 1/Q_gas + 1/q0).
//  - resonant frequency: baseline linear temperature coefficient (seed Eq.
//    5/8), residual in Hz; candidate quadratic_tc.
namespace gyrotc::identify {

enum class StaticQuantity { quality_factor, frequency_hz };

// Throws std::invalid_argument for fewer than 6 points, unequal lengths or a
// non-positive quality factor.
Identification identify_static(std::span<const double> temp_c, std::span<const double> value,
                               StaticQuantity quantity, const std::string& target,
                               const Criteria& criteria = {});

}  // namespace gyrotc::identify
