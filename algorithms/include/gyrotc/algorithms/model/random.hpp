#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace gyrotc::model {

// A small, fast, seedable random source for the simulation's noise:
// xoshiro256** (Blackman & Vigna) seeded through splitmix64, and standard
// normal deviates by the ziggurat method (Marsaglia & Tsang 2000, 128 layers;
// the layer index and the value come from disjoint bits of one 64-bit draw,
// avoiding the index/value correlation of the original). Deterministic for a
// seed on every platform (no std::normal_distribution, whose algorithm the
// standard leaves to the library). No allocation.
class Random {
 public:
  explicit Random(std::uint64_t seed) noexcept {
    std::uint64_t x = seed;
    for (auto& word : s_) word = splitmix64(x);
  }

  std::uint64_t next_u64() noexcept {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  // Uniform on [0, 1).
  double uniform() noexcept { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

  // Standard normal.
  double normal() noexcept {
    const Tables& t = tables();
    for (;;) {
      const std::uint64_t bits = next_u64();
      const auto i = static_cast<std::size_t>(bits & 127u);
      const auto hz = static_cast<std::int32_t>(static_cast<std::uint32_t>(bits >> 32));
      const double x = static_cast<double>(hz) * t.w[i];
      if (static_cast<std::uint32_t>(hz < 0 ? -static_cast<std::int64_t>(hz) : hz) < t.k[i]) return x;
      if (i == 0) {
        // The tail beyond r (Marsaglia's exponential rejection).
        double xt = 0.0;
        double y = 0.0;
        do {
          xt = -std::log(1.0 - uniform()) / kR;
          y = -std::log(1.0 - uniform());
        } while (y + y < xt * xt);
        return hz > 0 ? kR + xt : -kR - xt;
      }
      if (t.f[i] + uniform() * (t.f[i - 1] - t.f[i]) < std::exp(-0.5 * x * x)) return x;
    }
  }

 private:
  static constexpr double kR = 3.442619855899;        // Marsaglia & Tsang: 128-layer ziggurat
  static constexpr double kV = 9.91256303526217e-3;   // area of each layer
  struct Tables {
    std::uint32_t k[128];
    double w[128];
    double f[128];
    Tables() noexcept {
      const double m1 = 2147483648.0;  // 2^31
      double dn = kR;
      double tn = dn;
      const double q = kV / std::exp(-0.5 * dn * dn);
      k[0] = static_cast<std::uint32_t>((dn / q) * m1);
      k[1] = 0;
      w[0] = q / m1;
      w[127] = dn / m1;
      f[0] = 1.0;
      f[127] = std::exp(-0.5 * dn * dn);
      for (int i = 126; i >= 1; --i) {
        dn = std::sqrt(-2.0 * std::log(kV / dn + std::exp(-0.5 * dn * dn)));
        k[i + 1] = static_cast<std::uint32_t>((dn / tn) * m1);
        tn = dn;
        f[i] = std::exp(-0.5 * dn * dn);
        w[i] = dn / m1;
      }
    }
  };
  static const Tables& tables() noexcept {
    static const Tables t;
    return t;
  }

  static std::uint64_t rotl(std::uint64_t x, int k) noexcept { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t splitmix64(std::uint64_t& x) noexcept {
    std::uint64_t z = (x += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }

  std::uint64_t s_[4];
};

}  // namespace gyrotc::model
