#pragma once

#include <span>

namespace gyrotc::stats {

// Largest absolute value; 0 for an empty span.
double max_abs(std::span<const double> values);
// Root mean square; 0 for an empty span.
double rms(std::span<const double> values);
double mean(std::span<const double> values);

}  // namespace gyrotc::stats
