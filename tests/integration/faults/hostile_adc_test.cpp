// The real-time runner's loop (RealtimeRunner::step, lockstep) on the
// simulated board with a hostile ADS1251 reader: random wake-up latency with
// stalls past the DOUT window, late IRQ delivery, SPI messages that start
// late. The short version of scripts/hostile_adc.sh (10 minutes in real time):
// no corrupted sample may reach the controller, and every corrupted transfer
// must be among the late reads the runner reports.
#include <cmath>
#include <cstdint>
#include <string>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

namespace {

// The hostile reader: wake-ups up to 300 us late, 2 % stalls up to 3 ms,
// events readable up to 40 us after the edge and stamped up to as late (the
// stamping handler runs in an interrupt thread), SPI messages starting up to
// 100 us late.
hal::SimAds1251::Timing hostile_timing() {
  return {.wake_min_s = 0.0, .wake_max_s = 300e-6, .stall_probability = 0.02, .stall_max_s = 3e-3,
          .irq_delay_max_s = 40e-6, .stamp_delay_max_s = 40e-6, .spi_start_max_s = 100e-6,
          .spi_return_max_s = 50e-6, .seed = 0};
}

// What a run saw: the runner's counts, the simulator's truth.
struct HostileRun {
  app::LoopCounters loop;
  hal::SimAds1251::Counters chip;
  std::uint64_t accepted = 0, accepted_corrupted = 0;
  double conversions = 0.0;  // DRDY edges over the run
};

// 20 000 passes of the loop on the hostile board at 1 kSPS, the driver told
// that stamps are at most stamp_latency_max_s late.
HostileRun run_hostile(double stamp_latency_max_s) {
  app::DaemonConfig config = app::load_daemon_config(gyrotc::test::config_file("gyrotc-sim.toml"));
  config.board.sim.adc_timing = hostile_timing();
  config.board.devices.adc.stamp_latency_max_s = stamp_latency_max_s;
  app::BoardInstance instance = app::make_board(config.board, app::SimTiming::lockstep);
  hal::Board board = instance.board();
  const fit::Compensator compensator(fit::BiasModel::paper_reference());
  app::Controller controller(config.controller, compensator);
  app::RealtimeRunnerOptions options;
  options.sample_period_s = hal::Ads1251::kClocksPerSample / config.board.devices.adc.fclk_hz;
  app::RealtimeRunner runner(board, controller, options);
  runner.prime();
  const double start_s = board.clock.now_s();
  for (int i = 0; i < 20'000; ++i) runner.step();
  const hal::SimBoard& sim = *instance.sim_board;
  return {runner.counters(), sim.adc_chip().counters(), sim.accepted_samples(), sim.accepted_corrupted_samples(),
          std::floor(board.clock.now_s() / options.sample_period_s) - std::floor(start_s / options.sample_period_s)};
}

}  // namespace

TEST_CASE("hostile ADS1251: a kernel that stamps DRDY later than the driver allows for lets mixed reads through") {
  // DOUT mode ends 937.5 us after the edge; told the stamps are at most 2 us
  // late, the driver reads until 935.5 us after a stamp that may be 40 us late.
  const HostileRun r = run_hostile(2e-6);
  INFO("accepted " << r.accepted << ", of them corrupted " << r.accepted_corrupted);
  CHECK(r.accepted_corrupted > 0);
}

TEST_CASE("hostile ADS1251 at 1 kSPS: no corrupted sample accepted, every corrupted transfer counted late") {
  const HostileRun r = run_hostile(40e-6);  // the stamps' worst lateness, as the board's kernel shows it
  const app::LoopCounters& c = r.loop;
  INFO("samples " << c.samples << ", late reads " << c.late_reads << ", missed " << c.missed_conversions
                  << ", spurious " << c.spurious_edges << ", timeouts " << c.adc_timeouts << "; transfers "
                  << r.chip.reads << ", corrupted " << r.chip.corrupted_reads << ", conversions " << r.conversions);
  CHECK(r.accepted == c.samples);
  CHECK(r.accepted_corrupted == 0);
  CHECK(r.chip.corrupted_reads > 0);          // the run did produce mixed transfers...
  CHECK(c.late_reads >= r.chip.corrupted_reads);  // ...and the driver caught each one
  CHECK(c.missed_conversions > 0);
  // The pin's own edges are taken for noise only where they cannot be told
  // apart: a data bit of a read clocked past the window and stamped less than
  // 2 x stamp_latency_max_s before where the next DRDY may fall is taken for
  // that DRDY (its conversion skipped as missed), and then its MSB for noise.
  CHECK(c.spurious_edges <= c.late_reads);
  // Every conversion is read, dropped as late, or counted missed.
  CHECK(static_cast<double>(c.samples + c.late_reads + c.missed_conversions) == Approx(r.conversions).margin(3.0));
}
