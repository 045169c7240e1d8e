#pragma once

#include <cstddef>
#include <span>

// Statistics of a residual series used to score models.
namespace gyrotc::identify {

// Upper tail of the chi-square distribution with dof degrees of freedom.
double chi_square_sf(double x, double dof);

// Ljung-Box portmanteau test of whiteness over `lags` lags: the p-value
// (small = autocorrelated). lags is clamped to [1, n/2].
double ljung_box_p(std::span<const double> residual, std::size_t lags);

// Lag-1 autocorrelation, clamped to [0, 0.99].
double lag1_autocorrelation(std::span<const double> residual);

// Sample size of an AR(1) series worth n independent ones: n (1-rho)/(1+rho),
// at least 2.
double effective_sample_size(std::size_t n, double rho);

}  // namespace gyrotc::identify
