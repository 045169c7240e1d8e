#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

// Synthetic gyro rate records of known noise, for testing noise estimators
// (`gyrotc allan`) against the truth: the five terms of the IEEE Std 952
// Allan variance model, each generated as its own process and summed.
namespace gyrotc::model {

// Coefficients in the units of the rate u (e.g. deg/s) and seconds.
struct RateNoise {
  double quantisation = 0.0;      // Q, u s: white angle noise of standard deviation Q; AVAR 3 Q^2 / tau^2
  double arw = 0.0;               // N, u sqrt(s): white rate noise; AVAR N^2 / tau
  double bias_instability = 0.0;  // B, u: flicker (1/f) rate noise; AVAR floor (2 ln 2 / pi) B^2
  double rrw = 0.0;               // K, u / sqrt(s): random walk of the rate; AVAR K^2 tau / 3
  double ramp = 0.0;              // R, u / s: a linear rate drift; AVAR R^2 tau^2 / 2
};

// `samples` rate samples at rate_hz, each the mean rate over its sample
// period, deterministic for a seed (each term draws from its own stream).
// Flicker noise is Kasdin's fractional integration of white noise (N. J.
// Kasdin, "Discrete simulation of colored noise and stochastic processes
// and 1/f^alpha power law noise generation", Proc. IEEE 83(5), 1995):
// white deviates of standard deviation B filtered by h_0 = 1,
// h_k = h_{k-1} (k - 1/2) / k (an FFT convolution), whose one-sided spectrum
// B^2 / (pi f) gives the Allan floor (2 ln 2 / pi) B^2, i.e. B = floor / 0.664.
// The random walk (of which each sample is the mean over its period, so
// that AVAR = K^2 tau / 3 holds down to tau0) and the filter start at zero
// with the record.
std::vector<double> generate_rate_noise(const RateNoise& noise, double rate_hz, std::size_t samples,
                                        std::uint64_t seed);

}  // namespace gyrotc::model
