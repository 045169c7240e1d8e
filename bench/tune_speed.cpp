// Speed of `gyrotc tune` (issue 23: <= 2 s on a 3 h record): identification
// and design on a 3 h identification record of the nominal plant (the
// experiment with its PRBS phase lengthened to fill 3 h, recorded as the
// board records it, 1 row a second). Reports the record's rows and hours.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <string>

#include "gyrotc/algorithms/tune/experiment.hpp"
#include "gyrotc/app/tuning.hpp"

namespace {

gyrotc::app::TuneInput three_hour_record() {
  using namespace gyrotc;
  tune::ExperimentPlan plan;
  plan.prbs_s += 4800.0;  // the nominal plant's experiment takes 1 h 43 min
  const std::vector<app::RecordRow> rows = app::simulate_tune_experiment(model::PlantParams{}, 16.0, 20.0, plan).rows;
  app::TuneInput in;
  in.source = "3 h record";
  for (const auto& r : rows) {
    if (r.time_s > 3.0 * 3600.0) break;
    in.record.time_s.push_back(r.time_s);
    in.record.sensor_c.push_back(r.sensor_c);
    in.record.tec_a.push_back(r.tec_command_a);
    in.record.ambient_c.push_back(r.ambient_reading_c);
  }
  return in;
}

void BM_Tune3h(benchmark::State& state) {
  static const gyrotc::app::TuneInput input = three_hour_record();
  for (auto _ : state) {
    const gyrotc::app::TuneResult r = gyrotc::app::tune_from_record(input);
    benchmark::DoNotOptimize(r.controller.kp);
  }
  state.counters["rows"] = static_cast<double>(input.record.time_s.size());
  state.counters["hours"] = (input.record.time_s.back() - input.record.time_s.front()) / 3600.0;
}
BENCHMARK(BM_Tune3h)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace

BENCHMARK_MAIN();
