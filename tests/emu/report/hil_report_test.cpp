// The questions the hardware-in-the-loop checks ask of an emulator's event
// log, on logs and records made up here with known answers.
#include "gyrotc/emu/hil_report.hpp"

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

namespace {

emu::LogEvent plant(double t, double casing_c) { return {t, "plant", "casing_c", std::to_string(casing_c), ""}; }
emu::LogEvent tec(double t, unsigned code) { return {t, "dac", "tec_dac", std::to_string(code), "mode=normal;pid=7"}; }
emu::LogEvent es(double t, bool on) { return {t, "es", "drive", on ? "1" : "0", ""}; }

// A daemon's run: per-sample rates (noise around `mean`), each written to the
// rate DAC as its code, and the record's per-second means of the rates;
// start_s is the run's start on the log's clock.
struct Run {
  std::vector<emu::LogEvent> events;
  std::vector<emu::RecordRow> rows;
};
Run make_run(double start_s, double mean, const emu::DacScale& scale, double dac_gain = 1.0) {
  Run run;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.12);
  double sum = 0.0;
  int n = 0;
  for (int k = 1; k <= 3000; ++k) {  // 100 SPS for 30 s
    const double t = k * 0.01;
    const double rate = mean + noise(rng);
    const double v = 0.5 * scale.vref_v + dac_gain * rate * scale.v_per_dps;
    const auto code = static_cast<unsigned>(std::lround(v / scale.vref_v * 65536.0));
    run.events.push_back({start_s + t + 0.0002, "dac", "rate_dac", std::to_string(code), "mode=normal;pid=7"});
    sum += rate;
    ++n;
    if (k % 100 == 0) {
      run.rows.push_back({t, sum / n, 0});
      sum = 0.0;
      n = 0;
    }
  }
  return run;
}

}  // namespace

TEST_CASE("report settle: the first stretch of the true casing inside the band for the hold time") {
  std::vector<emu::LogEvent> e;
  for (int i = 0; i < 400; ++i) {
    const double t = i * 0.5;
    e.push_back(plant(t, t < 100.0 ? 25.0 + 0.3 * t : 55.0 + 0.1 * std::sin(t)));
  }
  const emu::SettleResult r = emu::find_settle(e, 55.0, 0.3, 60.0, 0.0);
  REQUIRE(r.settled);
  CHECK(r.settled_at_s == Approx(99.0).margin(0.6));  // where the ramp enters the band
  CHECK(r.max_abs_error_c <= 0.3);
  CHECK_FALSE(emu::find_settle(e, 55.0, 0.05, 60.0, 0.0).settled);  // the 0.1 C wobble leaves a 0.05 C band
}

TEST_CASE("report compensation: the codes the DAC latched match the record's means once its start is found") {
  const emu::DacScale scale{2.5, 0.01};
  const Run run = make_run(1000.0, 0.01, scale);
  const emu::CompensationResult r = emu::compare_compensation(run.events, run.rows, scale, 990.0, 2000.0, 990.0);
  CHECK(r.rows >= 25);
  CHECK(r.max_diff_lsb <= 1.0);
  CHECK(r.start_s == Approx(1000.0).margin(0.002));
  CHECK(std::fabs(r.mean_rate_dps - 0.01) < 0.01);
}

TEST_CASE("report compensation: a DAC written with the wrong scale does not match the record") {
  const emu::DacScale scale{2.5, 0.01};
  const Run run = make_run(1000.0, 0.5, scale, 1.02);  // 2 % scale error on the output
  const emu::CompensationResult r = emu::compare_compensation(run.events, run.rows, scale, 990.0, 2000.0, 990.0);
  CHECK(r.max_diff_lsb > 1.0);
}

TEST_CASE("report compensation: rows flagged ADC-invalid are left out") {
  const emu::DacScale scale{2.5, 0.01};
  Run run = make_run(1000.0, 0.0, scale);
  run.rows[10].rate_dps += 1.0;     // a row the DAC does not match ...
  run.rows[10].flags = 1u << 5;     // ... flagged ADC-invalid
  CHECK(emu::compare_compensation(run.events, run.rows, scale, 990.0, 2000.0, 990.0).max_diff_lsb <= 1.0);
}

TEST_CASE("report safe: the TEC path is safe when the DAC is at the 0 A code and E/S is low, both") {
  const std::vector<emu::LogEvent> e{tec(1.0, 40000), es(1.0, true),  tec(3.0, 40000), tec(5.0, 32768),
                                     es(5.002, false), tec(7.0, 32768), es(9.0, true), tec(9.0, 41000)};
  const emu::SafeResult r = emu::find_safe(e, 32768, 2.0);
  REQUIRE(r.safe_s);
  CHECK(*r.tec_zero_s == Approx(5.0));
  CHECK(*r.es_low_s == Approx(5.002));
  CHECK(*r.safe_s == Approx(5.002));
  REQUIRE(r.resumed_s);
  CHECK(*r.resumed_s == Approx(9.0));
  CHECK_FALSE(emu::find_safe(std::vector<emu::LogEvent>(e.begin(), e.begin() + 4), 32768, 2.0).safe_s);
}

TEST_CASE("report safe: with a TEC DAC that refuses frames, E/S low is the safe state and E/S high again the resume") {
  // The DAC keeps its last code (40000) through the SPI error; the daemon writes it again before enabling.
  const std::vector<emu::LogEvent> e{tec(1.0, 40000), es(1.0, true), es(4.0, false), es(9.0, true), tec(9.0, 41000)};
  const emu::SafeResult r = emu::find_safe(e, 32768, 2.0);
  CHECK_FALSE(r.safe_s);  // never both
  REQUIRE(r.es_low_s);
  CHECK(*r.es_low_s == Approx(4.0));
  REQUIRE(r.es_resumed_s);
  CHECK(*r.es_resumed_s == Approx(9.0));
}

TEST_CASE("report: the event log's last line still being written is left out, and a malformed line is named") {
  const std::string path = test::scratch_dir() + "/events.csv";
  std::ofstream(path) << "t_s,kind,device,value,detail\n1.0,mark,,start,\n2.0,plant,casing_c,25.0,x\n3.0,pla";
  const auto events = emu::read_event_log(path);
  REQUIRE(events.size() == 2);
  CHECK(emu::mark_time(events, "start") == 1.0);
  std::ofstream(path) << "t_s,kind,device,value,detail\n1.0,mark,,start,\nnot a line\n";
  try {
    (void)emu::read_event_log(path);
    FAIL("no error");
  } catch (const app::InputError& e) {
    CHECK_THAT(e.what(), Catch::Contains("events.csv:3"));
  }
}
