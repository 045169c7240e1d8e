// tune's fit on records whose truth is known exactly: the tune model itself
// (two nodes, TEC, rail) run through the identification experiment, read
// through a sensor with noise of its own (an AR(1) part with a time constant,
// like a mount's convection) and the DS18B20's 1/16 C steps and timing. The
// experiment reacts to the noisy readings, as on a board.
//
// What the fit's standard errors are worth is measured by the hidden cases
// "[.coverage]" and "[.coverage-by-noise]" (docs/TUNING.md quotes them).
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <random>
#include <string>

#include "gyrotc/algorithms/control/tec_law.hpp"
#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/algorithms/tune/thermal_identify.hpp"
#include "gyrotc/algorithms/tune/thermal_model.hpp"
#include "gyrotc_catch.hpp"
#include "sensor_steps.hpp"

using namespace gyrotc;

namespace {

// Near what tune finds on the plant simulator (docs/TUNING.md), with a rail
// the experiment's full current reaches.
tune::ThermalModel truth_model() {
  tune::ThermalModel m;
  m.peltier_per_a_s = 1.69e-4;
  m.joule_k_per_a2_s = 0.0118;
  m.loss_per_s = 3.3e-4;
  m.shell_ratio = 5.0;
  m.shell_tau_s = 80.0;
  m.internal_k_per_s = 2e-4;
  m.dead_time_s = 0.0;
  m.sensor_lag_s = 0.0;
  m.rail_a = 1.2;
  return m;
}

struct SensorNoise {
  double sd_c = 0.02;   // stationary sd of the AR(1) part
  double tau_s = 30.0;  // its time constant
};

// The board's record (as plant_record in thermal_identify_test.cpp): a
// conversion every second whose reading arrives 0.75 s later, the command
// every 2 s from the latest reading, a row a second; 16 C room, +/- 1 A.
tune::TuneRecord record(std::uint64_t seed, SensorNoise noise) {
  const tune::ThermalModel m = truth_model();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  constexpr double kRoomC = 16.0;
  constexpr double kStepS = 0.25;
  tune::ThermalState x{kRoomC + 0.3, kRoomC + 0.1};
  tune::IdentificationExperiment experiment;
  tune::TuneRecord r;
  const double phi = std::exp(-kStepS / noise.tau_s);
  double ar = noise.sd_c * normal(rng);
  double reading = test::ds18b20_steps_c(x.casing_c + ar);
  double pending = reading;
  double command = 0.0;
  for (int q = 0;; ++q) {
    const double t = q * kStepS;
    ar = phi * ar + noise.sd_c * std::sqrt(1.0 - phi * phi) * normal(rng);
    if (q % 4 == 0) pending = test::ds18b20_steps_c(x.casing_c + ar);
    if (q % 4 == 3) reading = pending;
    if (q % 8 == 0 && q > 0) {
      const control::TecProgramOutput o = experiment.next({t, reading, kRoomC, 55.0, -1.0, 1.0});
      if (o.finished) break;
      command = o.current_a;
    }
    if (q % 4 == 0 && q > 0) {
      r.time_s.push_back(t);
      r.sensor_c.push_back(reading);
      r.tec_a.push_back(command);
      r.ambient_c.push_back(kRoomC);
    }
    x = tune::step(m, x, command, kRoomC, kStepS);
  }
  return r;
}

constexpr const char* kNames[] = {"peltier_per_a_s", "joule_k_per_a2_s", "loss_per_s", "shell_ratio",
                                  "shell_tau_s",     "internal_k_per_s", "rail_a"};

double truth_of(const std::string& name) {
  const tune::ThermalModel m = truth_model();
  if (name == "peltier_per_a_s") return m.peltier_per_a_s;
  if (name == "joule_k_per_a2_s") return m.joule_k_per_a2_s;
  if (name == "loss_per_s") return m.loss_per_s;
  if (name == "shell_ratio") return m.shell_ratio;
  if (name == "shell_tau_s") return m.shell_tau_s;
  if (name == "internal_k_per_s") return m.internal_k_per_s;
  return m.rail_a;
}

}  // namespace

TEST_CASE("on noisy records the fit reaches the noise floor, not a minimum beside it", "[sweep]") {
  // Four restarts left 6 of these 20 records at rms 0.045 C, every parameter
  // 3-6 standard errors off; the floor is the sensor noise and the steps.
  const SensorNoise noise;
  const double floor_c = std::sqrt(noise.sd_c * noise.sd_c + 0.0625 * 0.0625 / 12.0);
  for (std::uint64_t seed = 100; seed < 120; ++seed) {
    const tune::ThermalFit fit = tune::identify_thermal(record(seed, noise));
    INFO("seed " << seed << ": rms " << fit.rms_c << " C, floor " << floor_c << " C");
    CHECK(fit.rms_c < 1.15 * floor_c);
  }
}

TEST_CASE("the noise model finds a slow sensor noise under the DS18B20's steps") {
  // 0.03 C with a 100 s time constant under the nearly white steps.
  const tune::ThermalFit fit = tune::identify_thermal(record(7, {0.03, 100.0}));
  CHECK(fit.lag1_autocorrelation < 0.9);
  INFO("slow part " << std::sqrt(fit.noise.slow_var) << " C, " << fit.noise.slow_tau_rows << " rows");
  CHECK(fit.noise.slow_tau_rows > 50.0);
  CHECK(fit.noise.slow_tau_rows < 200.0);
  CHECK(std::sqrt(fit.noise.slow_var) > 0.02);
  CHECK(std::sqrt(fit.noise.slow_var) < 0.045);
}

// How many of 50 records (seeds first_seed..first_seed+49; three sensor
// noises: 0.01/0.03 C, 10/100 s) have value +/- 1.96 se holding the truth,
// per parameter.
std::array<int, std::size(kNames)> covered_of_50(std::uint64_t first_seed) {
  std::array<int, std::size(kNames)> covered{};
  for (int s = 0; s < 50; ++s) {
    const SensorNoise noise{s % 3 == 0 ? 0.01 : 0.03, s % 2 == 0 ? 10.0 : 100.0};
    const tune::ThermalFit fit = tune::identify_thermal(record(first_seed + static_cast<std::uint64_t>(s), noise));
    for (std::size_t i = 0; i < std::size(kNames); ++i) {
      for (const tune::Estimate& e : fit.estimates) {
        if (e.name == kNames[i] && std::fabs(e.value - truth_of(e.name)) <= 1.96 * e.std_error) ++covered[i];
      }
    }
  }
  return covered;
}

TEST_CASE("tune's 95 % intervals hold the truth in at least 90 % of 50 records", "[.coverage]") {
  // Seeds 100..149 were used while developing the noise model; 1000..1049
  // were run only to measure it. The check is on the latter, with nothing
  // added to the intervals.
  const auto development = covered_of_50(100);
  const auto test = covered_of_50(1000);
  for (std::size_t i = 0; i < std::size(kNames); ++i) {
    std::printf("%-18s development %2d/50, test %2d/50\n", kNames[i], development[i], test[i]);
  }
  for (std::size_t i = 0; i < std::size(kNames); ++i) {
    INFO(kNames[i] << ": " << test[i] << " of 50 covered");
    CHECK(test[i] >= 45);
  }
}

TEST_CASE("tune's 95 % intervals per sensor noise, over 100 records each", "[.coverage-by-noise]") {
  // A measurement, not a check (docs/TUNING.md quotes it): seeds 5000..5099
  // under each noise of covered_of_50, misses of +/- 1.96 se and the rms of
  // (value - truth) / se per parameter.
  const SensorNoise noises[] = {{0.01, 10.0}, {0.01, 100.0}, {0.03, 10.0}, {0.03, 100.0}};
  constexpr int kRecords = 100;
  int total = 0;
  for (const SensorNoise& noise : noises) {
    std::array<int, std::size(kNames)> misses{};
    std::array<double, std::size(kNames)> z2{};
    for (int s = 0; s < kRecords; ++s) {
      const tune::ThermalFit fit = tune::identify_thermal(record(5000 + static_cast<std::uint64_t>(s), noise));
      for (std::size_t i = 0; i < std::size(kNames); ++i) {
        for (const tune::Estimate& e : fit.estimates) {
          if (e.name != kNames[i]) continue;
          const double z = (e.value - truth_of(e.name)) / e.std_error;
          z2[i] += z * z / kRecords;
          if (std::fabs(z) > 1.96) ++misses[i];
        }
      }
    }
    std::printf("sensor noise %.2f C, %3.0f s:", noise.sd_c, noise.tau_s);
    int sum = 0;
    for (std::size_t i = 0; i < std::size(kNames); ++i) {
      std::printf(" %s %d (rms z %.2f)", kNames[i], misses[i], std::sqrt(z2[i]));
      sum += misses[i];
    }
    std::printf("; %d of %d missed\n", sum, kRecords * static_cast<int>(std::size(kNames)));
    total += sum;
  }
  std::printf("in all: %d of %d missed\n", total, 4 * kRecords * static_cast<int>(std::size(kNames)));
}
