#pragma once

// The chi-square distribution for confidence intervals of variance
// estimates with (possibly fractional) equivalent degrees of freedom.
namespace gyrotc::stats {

// P(X <= x) for X chi-square with dof > 0 degrees of freedom.
double chi_square_cdf(double x, double dof);

// The p-quantile (0 < p < 1): the x with chi_square_cdf(x, dof) = p.
double chi_square_quantile(double p, double dof);

}  // namespace gyrotc::stats
