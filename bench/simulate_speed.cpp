// Speed of the lockstep chamber simulation: a full fig26 run at 1 kHz gyro
// sampling, >= 30 000x faster than real time (issue 35), with the rate ADC
// transaction-level (simulate's default; bit_level = 0) and bit-level (1),
// on the default plant (network = 0) and on a six-node network plant (1),
// which should run within 1.5x of the default.
// Reports the simulated-to-CPU-time ratio as the "speedup" counter.
#include <benchmark/benchmark.h>

#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/runtime/lockstep_runner.hpp"

namespace {

// A housing of six nodes: the TEC's hot side on a heat sink that warms, the
// casing DS18B20 on a heated board with its own lag, offset and noise, the
// gyro on a mount beside the die, the ambient sensor on the sink.
gyrotc::model::ThermalNetwork six_node_housing() {
  using gyrotc::model::kAmbientNode;
  gyrotc::model::ThermalNetwork n;
  n.nodes = {{"sink", 80.0, 0.0}, {"casing", 260.0, 0.0}, {"board", 40.0, 0.3},
             {"mount", 12.0, 0.0}, {"die", 1.6, 0.0},     {"lid", 30.0, 0.0}};
  n.links = {{kAmbientNode, 0, 0.6}, {0, 1, 0.02}, {1, 2, 0.5}, {1, 3, 0.3},
             {3, 4, 0.04},           {1, 5, 0.8},  {kAmbientNode, 5, 0.01}};
  n.tec_from = 0;
  n.tec_to = 1;
  n.casing_sensor = {2, 12.0, 0.15, 0.02};
  n.ambient_sensor = {0, 5.0, -0.1, 0.02};
  n.gyro_node = 4;
  return n;
}

void BM_SimulateFig26(benchmark::State& state) {
  const auto profile = gyrotc::app::chamber_profile_by_name("fig26", GYROTC_DATA_DIR);
  const auto calibration = gyrotc::fit::BiasModel::paper_reference();
  gyrotc::app::SimulationSetup setup;
  if (state.range(2) != 0) setup.plant.network = six_node_housing();
  setup.controller = gyrotc::app::controller_preset(gyrotc::app::ControllerMode::paper, setup.plant);
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
    ->ArgNames({"rate_hz", "bit_level", "network"})
    ->Args({1000, 0, 0})
    ->Args({1000, 1, 0})
    ->Args({1000, 0, 1})
    ->Unit(benchmark::kSecond)
    ->Iterations(3);

}  // namespace

BENCHMARK_MAIN();
