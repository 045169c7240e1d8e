// The real-time runner's loop (RealtimeRunner::step, lockstep) on the
// simulated board with a hostile ADS1251 reader: random wake-up latency with
// stalls past the DOUT window, late IRQ delivery, SPI messages that start
// late. The short version of scripts/hostile_adc.sh (10 minutes in real time):
// no corrupted sample may reach the controller, and every corrupted transfer
// must be among the late reads the runner reports.
#include <cmath>
#include <string>

#include "gyrotc/algorithms/fit/compensator.hpp"
#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/realtime_runner.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

using namespace gyrotc;

TEST_CASE("hostile ADS1251 at 1 kSPS: no corrupted sample accepted, every corrupted transfer counted late") {
  app::DaemonConfig config = app::load_daemon_config(gyrotc::test::config_file("gyrotc-sim.toml"));
  config.board.sim.adc_timing = {.wake_min_s = 0.0, .wake_max_s = 300e-6, .stall_probability = 0.02,
                                 .stall_max_s = 3e-3, .irq_delay_max_s = 40e-6, .spi_start_max_s = 100e-6,
                                 .spi_return_max_s = 50e-6, .seed = 0};
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
  const double conversions = std::floor(board.clock.now_s() / options.sample_period_s) -
                             std::floor(start_s / options.sample_period_s);

  const hal::SimBoard& sim = *instance.sim_board;
  const app::LoopCounters c = runner.counters();
  const hal::SimAds1251::Counters chip = sim.adc_chip().counters();
  INFO("samples " << c.samples << ", late reads " << c.late_reads << ", missed " << c.missed_conversions
                  << ", spurious " << c.spurious_edges << ", timeouts " << c.adc_timeouts << "; transfers "
                  << chip.reads << ", corrupted " << chip.corrupted_reads << ", conversions " << conversions);
  CHECK(sim.accepted_samples() == c.samples);
  CHECK(sim.accepted_corrupted_samples() == 0);
  CHECK(chip.corrupted_reads > 0);          // the run did produce mixed transfers...
  CHECK(c.late_reads >= chip.corrupted_reads);  // ...and the driver caught each one
  CHECK(c.missed_conversions > 0);
  CHECK(c.spurious_edges == 0);             // the pin's own edges are never noise
  // Every conversion is read, dropped as late, or counted missed.
  CHECK(static_cast<double>(c.samples + c.late_reads + c.missed_conversions) == Approx(conversions).margin(3.0));
}
