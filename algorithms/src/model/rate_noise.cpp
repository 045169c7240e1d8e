#include "gyrotc/algorithms/model/rate_noise.hpp"

#include <unsupported/Eigen/FFT>

#include <cmath>
#include <complex>
#include <stdexcept>

#include "gyrotc/algorithms/model/random.hpp"

namespace gyrotc::model {

namespace {

// Kasdin's 1/f sequence: white deviates of standard deviation sigma
// convolved with the fractional-integration filter of order 1/2, by FFT
// over a zero-padded length (a linear, not circular, convolution).
std::vector<double> flicker(std::size_t n, double sigma, Random& rng) {
  std::size_t size = 1;
  while (size < 2 * n) size *= 2;
  std::vector<double> h(size, 0.0);
  std::vector<double> w(size, 0.0);
  h[0] = 1.0;
  for (std::size_t k = 1; k < n; ++k) h[k] = h[k - 1] * (static_cast<double>(k) - 0.5) / static_cast<double>(k);
  for (std::size_t k = 0; k < n; ++k) w[k] = sigma * rng.normal();
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> hf;
  std::vector<std::complex<double>> wf;
  fft.fwd(hf, h);
  fft.fwd(wf, w);
  for (std::size_t k = 0; k < hf.size(); ++k) wf[k] *= hf[k];
  std::vector<double> out;
  fft.inv(out, wf);
  out.resize(n);
  return out;
}

}  // namespace

std::vector<double> generate_rate_noise(const RateNoise& noise, double rate_hz, std::size_t samples,
                                        std::uint64_t seed) {
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw std::invalid_argument("rate noise: rate_hz must be positive");
  for (double c : {noise.quantisation, noise.arw, noise.bias_instability, noise.rrw}) {
    if (!(c >= 0.0) || !std::isfinite(c)) throw std::invalid_argument("rate noise: coefficients must be >= 0");
  }
  if (!std::isfinite(noise.ramp)) throw std::invalid_argument("rate noise: ramp must be finite");
  const double tau0 = 1.0 / rate_hz;
  std::vector<double> y(samples, 0.0);
  // One stream per term: a record with a term switched off keeps the others' draws.
  Random white(seed * 5 + 1);
  Random quant(seed * 5 + 2);
  Random walk(seed * 5 + 3);
  Random pink(seed * 5 + 4);
  if (noise.arw > 0.0) {
    const double sigma = noise.arw / std::sqrt(tau0);
    for (double& v : y) v += sigma * white.normal();
  }
  if (noise.quantisation > 0.0) {
    // Rate of a white angle error e: (e_k - e_{k-1}) / tau0.
    double previous = noise.quantisation * quant.normal();
    for (double& v : y) {
      const double e = noise.quantisation * quant.normal();
      v += (e - previous) / tau0;
      previous = e;
    }
  }
  if (noise.rrw > 0.0) {
    // The mean over each sample period of a continuous random walk W(t):
    // with the walk's step over the period dW (variance K^2 tau0), the mean
    // lies dW / 2 above the start plus an independent part of variance
    // K^2 tau0 / 12 (the Brownian bridge's mean). Its Allan variance is
    // K^2 tau / 3 at every tau; point samples of W would add K^2 tau0^2 / (6 tau).
    const double step = noise.rrw * std::sqrt(tau0);
    const double bridge = noise.rrw * std::sqrt(tau0 / 12.0);
    double start = 0.0;
    for (double& v : y) {
      const double dw = step * walk.normal();
      v += start + 0.5 * dw + bridge * walk.normal();
      start += dw;
    }
  }
  if (noise.bias_instability > 0.0 && samples > 0) {
    const std::vector<double> f = flicker(samples, noise.bias_instability, pink);
    for (std::size_t k = 0; k < samples; ++k) y[k] += f[k];
  }
  if (noise.ramp != 0.0) {
    for (std::size_t k = 0; k < samples; ++k) y[k] += noise.ramp * tau0 * (static_cast<double>(k) + 0.5);
  }
  return y;
}

}  // namespace gyrotc::model
