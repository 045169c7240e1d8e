#pragma once

#include <cstddef>
#include <span>

// Statistics of a residual series used to score models.
namespace gyrotc::identify {

// Upper tail of the chi-square distribution with dof degrees of freedom.
double chi_square_sf(double x, double dof);

// Upper tail of the F distribution with (dof1, dof2) degrees of freedom.
double f_sf(double f, double dof1, double dof2);

// Ljung-Box portmanteau test of whiteness over `lags` lags: the p-value
// (small = autocorrelated). lags is clamped to [1, n/2].
double ljung_box_p(std::span<const double> residual, std::size_t lags);

// Long-run variance over variance of a series (Newey-West: Bartlett weights
// up to `bandwidth` lags), at least 1: the factor by which serial correlation
// the noise model left behind inflates the variance of sums, so the evidence
// counts n / factor independent samples. bandwidth 0 picks Newey and West's
// (1994) rule floor(4 (n/100)^(2/9)).
double long_run_variance_factor(std::span<const double> residual, std::size_t bandwidth = 0);

// The first lag (1 .. max_lag - 1) at which the series' autocorrelation is
// below `below`; 0 if none is (or the series is constant).
std::size_t decorrelation_lag(std::span<const double> residual, double below, std::size_t max_lag);

// Lag-1 autocorrelation of a residual series, clamped to [0, 0.99] (tune's
// thermal fit reports it and inflates its covariance by it).
double lag1_autocorrelation(std::span<const double> residual);

// Samples worth of independent information in n AR(1) samples with lag-1
// correlation rho: n (1 - rho) / (1 + rho), at least 2.
double effective_sample_size(std::size_t n, double rho);

}  // namespace gyrotc::identify
