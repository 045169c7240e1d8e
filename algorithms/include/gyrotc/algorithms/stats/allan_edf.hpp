#pragma once

#include <cstddef>

// Equivalent degrees of freedom (EDF) of the overlapping Allan variance
// estimate for power-law noise, by Greenhall's algorithm (C. A. Greenhall and
// W. J. Riley, "Uncertainty of stability variances based on finite
// differences", 35th PTTI Meeting, 2003; the method IEEE Std 1139-2008 and
// NIST SP 1065 refer to). The estimate of a variance sigma^2 with EDF nu is
// distributed as sigma^2 chi^2_nu / nu.
namespace gyrotc::stats {

// Power-law noise of the rate, S_y(f) ~ f^alpha, named by its gyro term.
enum class PowerLawNoise {
  quantisation,      // alpha = +2: white angle (phase) noise, AVAR ~ tau^-2
  white_rate,        // alpha =  0: angle random walk, AVAR ~ tau^-1
  flicker_rate,      // alpha = -1: bias instability, AVAR flat
  random_walk_rate,  // alpha = -2: rate random walk, AVAR ~ tau
};

// EDF of the overlapping Allan variance at cluster size m (tau = m tau0)
// from a record of `samples` rate samples (samples + 1 angle points), for
// one noise type. Needs 1 <= m <= samples / 2.
double overlapping_avar_edf(PowerLawNoise noise, std::size_t m, std::size_t samples);

// The simple approximations of Howe, Allan & Barnes (1981) (NIST SP 1065,
// Table 5), kept as an independent check of the algorithm above.
double overlapping_avar_edf_simple(PowerLawNoise noise, std::size_t m, std::size_t samples);

}  // namespace gyrotc::stats
