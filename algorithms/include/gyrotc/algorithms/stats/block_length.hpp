#pragma once

#include <span>

namespace gyrotc::stats {

// The block length (in samples) for a moving-block bootstrap of a stationary
// series, chosen from the series' own autocovariance: Politis & White (2004),
// "Automatic block-length selection for the dependent bootstrap", with the
// correction of Patton, Politis & White (2009). The autocorrelations are cut
// where they stop differing from zero (2 sqrt(log10 n / n), for 5 lags in a
// row), a flat-top window of twice that lag weighs them, and
//   b = (2 G^2 / D)^(1/3) n^(1/3),  G = sum |k| w(k) R(k),  D = 4/3 (sum w(k) R(k))^2,
// clamped to 1 .. n / 3. A white series gets 1. Throws std::invalid_argument
// for fewer than 16 samples or a non-finite one.
double block_bootstrap_length(std::span<const double> series);

}  // namespace gyrotc::stats
