// Speed of the lockstep chamber simulation: a full fig26 run at 1 kHz gyro
// sampling, >= 30 000x faster than real time (issue 35), with the rate ADC
// transaction-level (simulate's default; bit_level = 0) and bit-level (1),
// on the default plant (network = 0) and on a six-node network plant (1),
// which should run within 1.5x of the default; and on that network plant
// with the model-based loop that knows it (controller = 1, `--controller
// oracle`) in the paper's PID's place.
// Reports the simulated-to-CPU-time ratio as the "speedup" counter.
#include <benchmark/benchmark.h>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"
#include "six_node_housing.hpp"

namespace {

void BM_SimulateFig26(benchmark::State& state) {
  const auto profile = gyrotc::app::chamber_profile_by_name("fig26", GYROTC_DATA_DIR);
  const auto calibration = gyrotc::fit::BiasModel::paper_reference();
  gyrotc::app::SimulationSetup setup;
  if (state.range(2) != 0) setup.plant.network = gyrotc::bench::six_node_housing();
  setup.controller = gyrotc::app::controller_preset(
      state.range(3) != 0 ? gyrotc::app::ControllerMode::oracle : gyrotc::app::ControllerMode::paper, setup.plant);
  setup.calibration = &calibration;
  setup.sample_rate_hz = static_cast<double>(state.range(0));
  setup.adc_model = state.range(1) == 0 ? gyrotc::hal::SimAdcModel::transaction : gyrotc::hal::SimAdcModel::bit_level;
  double simulated_s = 0.0;
  for (auto _ : state) {
    auto result = gyrotc::app::run_simulation(setup, profile);
    simulated_s += result.summary.simulated_s;
    benchmark::DoNotOptimize(result.summary.settle_s);
  }
  state.counters["speedup"] = benchmark::Counter(simulated_s, benchmark::Counter::kIsRate);
  state.counters["samples_per_s"] =
      benchmark::Counter(simulated_s * static_cast<double>(state.range(0)), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateFig26)
    ->ArgNames({"rate_hz", "bit_level", "network", "controller"})
    ->Args({1000, 0, 0, 0})
    ->Args({1000, 1, 0, 0})
    ->Args({1000, 0, 1, 0})
    ->Args({1000, 0, 1, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
