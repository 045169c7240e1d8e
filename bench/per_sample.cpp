// Per-sample cost of the controller (issue 10): every piece the real-time
// loop runs for one ADC sample, and the whole path, in ns per sample and as
// a share of the 50 us period of a 20 kSPS ADC.
//
// Counters (read by scripts/bench.sh from --benchmark_out JSON):
//   ns_per_sample       CPU time per iteration, ns
//   share_20ksps_pct    that time as a percentage of 50 us
//
// The chip drivers run over in-memory buses (a frame ready at once, a DAC
// that takes any frame) so that what is timed is our code, not a simulator;
// the SimBoard variant times the same path through the bit-level chip
// simulators and the plant, as the lockstep runner runs it.
#include <benchmark/benchmark.h>

#include <time.h>

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "gyrotc/algorithms/control/pid.hpp"
#include "gyrotc/algorithms/fit/bias_model.hpp"
#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/algorithms/fit/fit_method.hpp"
#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/sim/sim_board.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"

namespace {

using gyrotc::fit::BiasModel;

constexpr double kPeriod20kSps_s = 50e-6;

// The loop's CPU time (this thread), as ns per sample and as a share of a
// 20 kSPS period. Plain counters, so the console shows the numbers as they
// are (a rate counter would print them with a misleading "s" suffix).
class PerSample {
 public:
  PerSample() noexcept : start_ns_(thread_cpu_ns()) {}
  void report(benchmark::State& state) const {
    const double ns = (thread_cpu_ns() - start_ns_) / static_cast<double>(state.iterations());
    state.counters["ns_per_sample"] = ns;
    state.counters["share_20ksps_pct"] = ns * 1e-9 / kPeriod20kSps_s * 100.0;
  }

 private:
  static double thread_cpu_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
  }
  double start_ns_;
};

// An SPI bus that answers every transfer with the next of a few ADC frames
// (varying codes, so nothing is constant-folded) and accepts any DAC frame.
class MemorySpi final : public gyrotc::hal::SpiBus {
 private:
  gyrotc::hal::Status do_configure(const gyrotc::hal::SpiConfig&) noexcept override { return {}; }
  gyrotc::hal::Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override {
    static constexpr std::array<std::uint32_t, 4> kFrames{0x012345, 0xFEDCBA, 0x000F00, 0x7FF000};
    const std::uint32_t frame = kFrames[next_++ & 3u];
    for (std::size_t i = 0; i < rx.size() && i < 3; ++i) rx[i] = static_cast<std::uint8_t>(frame >> (16 - 8 * i));
    benchmark::DoNotOptimize(tx.data());
    return {};
  }
  std::string_view do_name() const noexcept override { return "memory"; }
  unsigned next_ = 0;
};

// A DRDY line whose edge has always just come: every wait returns the next
// 1 kSPS edge with the clock 40 us after it (past the driver's hold-off, well
// inside the DOUT window), so the driver never sleeps.
class ReadyLine final : public gyrotc::hal::GpioLine {
 public:
  gyrotc::hal::Clock& clock() noexcept { return clock_; }

 private:
  gyrotc::hal::Status do_set(bool) noexcept override { return {}; }
  gyrotc::hal::Result<bool> do_get() noexcept override { return false; }
  gyrotc::hal::Result<double> do_wait_edge(gyrotc::hal::Edge, double) noexcept override {
    edge_s_ += 1e-3;
    clock_.sleep_until(edge_s_ + 40e-6);
    return edge_s_;
  }
  std::string_view do_name() const noexcept override { return "ready"; }
  gyrotc::hal::VirtualClock clock_;
  double edge_s_ = 0.0;
};

// The seed's Table 2, fitted once by each method of `gyrotc fit`.
struct Models {
  BiasModel polynomial;
  BiasModel piecewise;
  BiasModel bp_network;
  BiasModel paper_reference;
  BiasModel spline;  // the penalised spline (`fit --method smooth`, what auto ships for Table 2): 25 knots
};

const Models& models() {
  static const Models m = [] {
    const auto table = gyrotc::app::CsvTable::read(std::string(GYROTC_DATA_DIR) + "/table2_zero_bias.csv");
    const std::vector<double> temp_c = table.numbers("temp_c");
    const std::vector<double> gyro_mv = table.numbers("gyro_mv");
    auto fit = [&](gyrotc::fit::Method method) {
      gyrotc::fit::MethodOptions o;
      o.method = method;
      o.bp.restarts = 1;  // inference cost does not depend on the training's luck
      return gyrotc::fit::fit_method(temp_c, gyro_mv, o).model;
    };
    return Models{fit(gyrotc::fit::Method::polynomial), fit(gyrotc::fit::Method::piecewise),
                  fit(gyrotc::fit::Method::bp_network), BiasModel::paper_reference(),
                  fit(gyrotc::fit::Method::smoothing)};
  }();
  return m;
}

const BiasModel& model_of(std::int64_t kind) {
  switch (static_cast<BiasModel::Kind>(kind)) {
    case BiasModel::Kind::polynomial: return models().polynomial;
    case BiasModel::Kind::piecewise: return models().piecewise;
    case BiasModel::Kind::bp_network: return models().bp_network;
    case BiasModel::Kind::spline: return models().spline;
    case BiasModel::Kind::paper_reference: break;
  }
  return models().paper_reference;
}

void label_kind(benchmark::State& state) { state.SetLabel(std::string(model_of(state.range(0)).kind_name())); }

// Temperatures swept over the calibrated range, so every segment is visited.
std::vector<double> sweep(const BiasModel& model) {
  std::vector<double> t(256);
  for (std::size_t i = 0; i < t.size(); ++i) {
    t[i] = model.t_min_c() + (model.t_max_c() - model.t_min_c()) * static_cast<double>(i) / 255.0;
  }
  return t;
}

// --- pieces -------------------------------------------------------------------

void BM_Ads1251Decode(benchmark::State& state) {
  // 3 received bytes -> sign-extended code -> mV, as Ads1251::read does.
  MemorySpi spi;
  ReadyLine drdy;
  const gyrotc::hal::Ads1251 adc(spi, drdy, drdy.clock(), {});
  std::array<std::uint8_t, 12> bytes{0x01, 0x23, 0x45, 0xFE, 0xDC, 0xBA, 0x00, 0x0F, 0x00, 0x7F, 0xF0, 0x00};
  std::size_t i = 0;
  const PerSample timer;
  for (auto _ : state) {
    benchmark::DoNotOptimize(bytes.data());
    const std::uint8_t* b = &bytes[i];
    i = (i + 3) % bytes.size();
    const std::int32_t code = gyrotc::hal::Ads1251::sign_extend_24(
        static_cast<std::uint32_t>(b[0]) << 16 | static_cast<std::uint32_t>(b[1]) << 8 | b[2]);
    double mv = adc.code_to_mv(code);
    benchmark::DoNotOptimize(mv);
  }
  timer.report(state);
}
BENCHMARK(BM_Ads1251Decode);

void BM_Ads1251Read(benchmark::State& state) {
  // The driver's whole read: DRDY wait, 3-byte transfer, decode (virtual calls included).
  MemorySpi spi;
  ReadyLine drdy;
  gyrotc::hal::Ads1251 adc(spi, drdy, drdy.clock(), {});
  gyrotc::hal::RateAdc& rate_adc = adc;
  const PerSample timer;
  for (auto _ : state) {
    auto sample = rate_adc.read(1.0);
    benchmark::DoNotOptimize(sample);
  }
  timer.report(state);
}
BENCHMARK(BM_Ads1251Read);

void BM_Compensate(benchmark::State& state) {
  // One model evaluation per call: what the controller pays per new casing reading.
  const gyrotc::fit::Compensator comp(model_of(state.range(0)));
  const std::vector<double> temps = sweep(comp.model());
  std::size_t i = 0;
  const PerSample timer;
  for (auto _ : state) {
    auto c = comp.compensate(1.0 + static_cast<double>(i & 7u), temps[i & 255u]);
    ++i;
    benchmark::DoNotOptimize(c);
  }
  label_kind(state);
  timer.report(state);
}
BENCHMARK(BM_Compensate)->DenseRange(0, 4);

void BM_BpInference(benchmark::State& state) {
  // The BP network alone (1-10-10-10-1 tansig, seed Section 4.1), no clamping.
  const gyrotc::fit::BpNetwork& net = *models().bp_network.as_bp_network();
  const std::vector<double> temps = sweep(models().bp_network);
  std::size_t i = 0;
  const PerSample timer;
  for (auto _ : state) {
    double mv = gyrotc::fit::evaluate(net, temps[i++ & 255u]);
    benchmark::DoNotOptimize(mv);
  }
  timer.report(state);
}
BENCHMARK(BM_BpInference);

void BM_Ad5060Encode(benchmark::State& state) {
  // Volts -> nearest code -> 24-bit frame.
  double volts = 0.0;
  const PerSample timer;
  for (auto _ : state) {
    volts = volts > 4.9 ? 0.0 : volts + 0.0173;
    std::uint32_t frame = gyrotc::hal::Ad5060::frame(gyrotc::hal::Ad5060::code_for_v(volts, 5.0),
                                                     gyrotc::hal::Ad5060PowerDown::normal);
    benchmark::DoNotOptimize(frame);
  }
  timer.report(state);
}
BENCHMARK(BM_Ad5060Encode);

void BM_Ad5060Write(benchmark::State& state) {
  // The driver's write_v: encode and the 3-byte transfer (virtual calls included).
  MemorySpi spi;
  gyrotc::hal::Ad5060 dac(spi, {.vref_v = 5.0});
  gyrotc::hal::RateDac& rate_dac = dac;
  double volts = 0.0;
  const PerSample timer;
  for (auto _ : state) {
    volts = volts > 4.9 ? 0.0 : volts + 0.0173;
    auto s = rate_dac.write_v(volts);
    benchmark::DoNotOptimize(s);
  }
  timer.report(state);
}
BENCHMARK(BM_Ad5060Write);

void BM_PidStep(benchmark::State& state) {
  // One step of the integral-separated incremental PID (seed Eq. 17/18).
  gyrotc::control::IncrementalPid pid(gyrotc::control::PidParams{});
  double measured = 54.0;
  const PerSample timer;
  for (auto _ : state) {
    measured = measured > 56.0 ? 54.0 : measured + 0.01;
    double u = pid.step(measured, 55.0);
    benchmark::DoNotOptimize(u);
  }
  timer.report(state);
}
BENCHMARK(BM_PidStep);

// --- the whole per-sample path ----------------------------------------------------

// Ads1251::read -> run_sample_tick (Controller::on_sample, Ad5060::write_v and
// the row sums, as both runners do it), over in-memory buses. Arg 0: the model
// kind. Arg 1: 0 = steady (the casing reading comes about once a second, so
// the controller subtracts a cached bias), 1 = a new casing reading before
// every sample (one model evaluation every sample: the worst case).
void BM_SamplePath(benchmark::State& state) {
  const gyrotc::fit::Compensator comp(model_of(state.range(0)));
  const bool new_reading_each_sample = state.range(1) != 0;
  gyrotc::app::Controller controller(gyrotc::app::ControllerConfig{}, comp);
  MemorySpi adc_spi;
  ReadyLine drdy;
  gyrotc::hal::Ads1251 adc(adc_spi, drdy, drdy.clock(), {});
  MemorySpi dac_spi;
  gyrotc::hal::Ad5060 dac(dac_spi, {.vref_v = 5.0});
  gyrotc::hal::RateAdc& rate_adc = adc;
  gyrotc::hal::RateDac& rate_dac = dac;
  const std::vector<double> temps = sweep(comp.model());
  double now_s = 0.0;
  controller.on_temperature({.temp_c = 25.0, .time_s = 0.0, .valid = true}, 0.0);
  std::size_t i = 0;
  gyrotc::app::RowAccumulator row;
  const PerSample timer;
  for (auto _ : state) {
    now_s += 1e-3;
    if (new_reading_each_sample) {
      controller.on_temperature({.temp_c = temps[i++ & 255u], .time_s = now_s, .valid = true}, now_s);
    }
    const auto sample = rate_adc.read(1.0);
    if (sample) {
      auto r = gyrotc::app::run_sample_tick(controller, rate_dac, *sample, now_s, row);
      benchmark::DoNotOptimize(r);
    } else {
      gyrotc::app::run_adc_timeout_tick(controller, rate_dac, now_s, row);
    }
  }
  benchmark::DoNotOptimize(row);
  state.SetLabel(std::string(comp.model().kind_name()) + (new_reading_each_sample ? " new-reading" : " steady"));
  timer.report(state);
}
BENCHMARK(BM_SamplePath)->ArgsProduct({{0, 1, 2, 3, 4}, {0, 1}});

// The same path through the lockstep SimBoard (1 kSPS, the sim config's
// rate): the bit-level ADS1251 and AD5060 simulators, the gyro noise, and
// the plant stepped every 0.1 s of virtual time, amortised over its samples.
void BM_SamplePathSimBoard(benchmark::State& state) {
  const gyrotc::fit::Compensator comp(BiasModel::paper_reference());
  gyrotc::app::Controller controller(gyrotc::app::ControllerConfig{}, comp);
  gyrotc::model::PlantParams plant;
  gyrotc::hal::SimBoard sim(plant, 1, {});
  gyrotc::hal::Board board = sim.board();
  controller.on_temperature({.temp_c = 25.0, .time_s = 0.0, .valid = true}, 0.0);
  gyrotc::app::RowAccumulator row;
  const PerSample timer;
  for (auto _ : state) {
    const auto sample = board.adc.read(3e-3);
    if (sample) {
      auto r = gyrotc::app::run_sample_tick(controller, board.rate_dac, *sample, sample->time_s, row);
      benchmark::DoNotOptimize(r);
    } else {
      gyrotc::app::run_adc_timeout_tick(controller, board.rate_dac, board.clock.now_s(), row);
    }
  }
  benchmark::DoNotOptimize(row);
  timer.report(state);
}
BENCHMARK(BM_SamplePathSimBoard);

}  // namespace

BENCHMARK_MAIN();
