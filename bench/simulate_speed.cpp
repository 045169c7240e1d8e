// Speed of the lockstep chamber simulation (issue 4: a full fig26 run at
// 1 kHz gyro sampling >= 10 000x faster than real time). Reports the
// simulated-to-CPU-time ratio as the "speedup" counter.
#include <benchmark/benchmark.h>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"

namespace {

void BM_SimulateFig26(benchmark::State& state) {
  const auto profile = gyrotc::app::chamber_profile_by_name("fig26", GYROTC_DATA_DIR);
  const auto calibration = gyrotc::fit::BiasModel::paper_reference();
  gyrotc::app::SimulationSetup setup;
  setup.controller = gyrotc::app::controller_preset(gyrotc::app::ControllerMode::paper, setup.plant);
  setup.calibration = &calibration;
  setup.sample_rate_hz = static_cast<double>(state.range(0));
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
BENCHMARK(BM_SimulateFig26)->Arg(1000)->Unit(benchmark::kSecond)->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
