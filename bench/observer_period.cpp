// One period of the model-based temperature loop (issue 72): the filter's
// update with a casing reading (and an ambient one every tenth period, as the
// board converts it), the holding current, the feedback and the prediction,
// as TecLoop runs it on the real-time thread once a second. Three housings:
// the one `tune --loop observer` identifies from a record (casing, shell, the
// sensor's node and lag: 4 states), the default plant as the reference loop
// sees it (3 nodes) and a six-node network with both sensors lagged (8).
// Reports the CPU time per period ("us_per_period") and its share of the 1 s
// period.
#include <benchmark/benchmark.h>

#include <time.h>

#include <cmath>
#include <limits>
#include <memory>

#include "gyrotc/algorithms/control/observer_loop.hpp"
#include "gyrotc/algorithms/model/plant_housing.hpp"
#include "gyrotc/algorithms/tune/identified_housing.hpp"
#include "six_node_housing.hpp"

namespace {

using gyrotc::control::HousingModel;
using gyrotc::control::ObserverLoop;
using gyrotc::control::ObserverLoopDesign;
using gyrotc::control::ObserverLoopSpec;

double thread_cpu_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

// tune's model of a unit whose sensor sits a minute behind the casing.
HousingModel identified() {
  gyrotc::tune::ThermalModel m;
  m.peltier_per_a_s = 1.5e-4;
  m.joule_k_per_a2_s = 0.016;
  m.loss_per_s = 2.6e-4;
  m.shell_ratio = 4.0;
  m.shell_tau_s = 300.0;
  m.internal_k_per_s = 1e-3;
  m.dead_time_s = 14.0;
  m.sensor_lag_s = 62.0;
  m.rail_a = 1.05;
  return gyrotc::tune::identified_housing(m, 1.0);
}

HousingModel six_nodes() {
  gyrotc::model::PlantParams p;
  p.network = gyrotc::bench::six_node_housing();
  return gyrotc::model::housing_model(p);
}

HousingModel housing(int which) {
  if (which == 0) return identified();
  if (which == 1) return gyrotc::model::housing_model(gyrotc::model::PlantParams{});
  return six_nodes();
}

void BM_ObserverPeriod(benchmark::State& state) {
  ObserverLoopSpec spec;
  spec.reading_noise_c = 0.02;
  const HousingModel model = housing(static_cast<int>(state.range(0)));
  ObserverLoop loop(std::make_shared<const ObserverLoopDesign>(gyrotc::control::design_observer_loop(model, spec)));
  // Held near the setpoint, the reading moving over two steps as a held
  // casing's does, so the quantised update takes both of its branches.
  int k = 0;
  double current_a = 0.0;
  const double start_ns = thread_cpu_ns();
  for (auto _ : state) {
    const double reading_c = 55.0 + 0.0625 * static_cast<double>((k / 7) % 3 - 1);
    const double ambient_c = k % 10 == 0 ? 16.0 : std::numeric_limits<double>::quiet_NaN();
    current_a = loop.tick(reading_c, 0.75, ambient_c, 55.0, -1.0, 1.0);
    benchmark::DoNotOptimize(current_a);
    ++k;
  }
  const double us = (thread_cpu_ns() - start_ns) * 1e-3 / static_cast<double>(state.iterations());
  state.counters["us_per_period"] = us;
  state.counters["share_of_1s_pct"] = us * 1e-6 / spec.period_s * 100.0;
  state.counters["states"] = model.state_count();
}
BENCHMARK(BM_ObserverPeriod)->ArgName("housing")->Arg(0)->Arg(1)->Arg(2);

}  // namespace

BENCHMARK_MAIN();
