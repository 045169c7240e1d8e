#include "gyrotc/hal/sim/sim_board.hpp"

#include <atomic>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "gyrotc_catch.hpp"

using namespace gyrotc;
using namespace gyrotc::hal;

namespace {

model::PlantParams params_at(double temp_c) {
  model::PlantParams p;
  p.initial_temp_c = temp_c;
  return p;
}

SimBoardOptions realtime() {
  SimBoardOptions options;
  options.realtime = true;
  return options;
}

}  // namespace

TEST_CASE("lockstep: each ADC read moves virtual time to the next conversion and steps the plant coarsely") {
  SimBoard sim{params_at(25.0), 7};
  Board board = sim.board();
  double last_s = 0.0;
  for (int i = 0; i < 1000; ++i) {
    const auto sample = board.adc.read(0.01);
    REQUIRE(sample.ok());
    last_s = sample->time_s;
  }
  CHECK(last_s == Approx(1.0));
  // The read ends a wake-up, the hold-off and 24 SCLKs after the edge.
  CHECK(board.clock.now_s() > 1.0);
  CHECK(board.clock.now_s() < 1.0 + 906e-6);
  CHECK(sim.plant().time_s() > 1.0 - sim.options().thermal_step_s - 1e-9);
  CHECK(sim.plant().time_s() <= board.clock.now_s() + 1e-9);
}

TEST_CASE("lockstep: ADC samples are the plant's gyro voltage through the 24-bit converter") {
  SimBoard sim{params_at(25.0), 7};
  Board board = sim.board();
  double sum_mv = 0.0;
  const int n = 2000;
  for (int i = 0; i < n; ++i) sum_mv += board.adc.read(0.01)->gyro_mv;
  // The noise averages down; what remains is the plant's zero-rate output.
  CHECK(sum_mv / n == Approx(sim.plant().gyro_bias_mv()).margin(1.0));
}

TEST_CASE("the rate applied to the plant shows in the ADC samples at the scale factor") {
  SimBoard sim{params_at(25.0), 3};
  Board board = sim.board();
  double zero_mv = 0.0;
  for (int i = 0; i < 1000; ++i) zero_mv += board.adc.read(0.01)->gyro_mv / 1000.0;
  sim.set_rate_dps(50.0);
  sim.advance_to(1.2);  // applied at the next plant step
  double rate_mv = 0.0;
  for (int i = 0; i < 1000; ++i) rate_mv += board.adc.read(0.01)->gyro_mv / 1000.0;
  CHECK(rate_mv - zero_mv == Approx(50.0 * 8.774).margin(2.0));  // seed Table 2 note: 8.774 mV/(deg/s)
}

TEST_CASE("the board starts safe: TEC DAC at mid-scale, OPA548 off, rate output at mid-scale") {
  SimBoard sim{params_at(25.0), 1};
  CHECK(sim.tec_dac_chip().code() == 32768);
  CHECK_FALSE(sim.opa548_chip().drive_released());
  CHECK(sim.rate_dac_chip().code() == 32768);
  CHECK(sim.plant().tec_current_a() == 0.0);
}

TEST_CASE("the TEC driver's current reaches the plant, and safe_off brings it to 0 A") {
  SimBoard sim{params_at(25.0), 1};
  Board board = sim.board();
  REQUIRE(board.tec.set_current_a(1.0).ok());
  REQUIRE(board.tec.enable(true).ok());
  sim.advance_to(1.0);
  CHECK(sim.plant().tec_current_a() == Approx(1.0).margin(0.01));
  REQUIRE(board.tec.safe_off().ok());
  sim.advance_to(2.0);
  CHECK(sim.plant().tec_current_a() == 0.0);
  CHECK_FALSE(sim.plant().tec_enabled());
}

TEST_CASE("heating through the TEC warms the casing the DS18B20 reads") {
  SimBoard sim{params_at(20.0), 1};
  Board board = sim.board();
  const auto before = board.casing_sensor.read();
  REQUIRE(before.valid);
  CHECK(before.temp_c == Approx(20.0).margin(0.07));
  REQUIRE(board.tec.set_current_a(1.0).ok());
  REQUIRE(board.tec.enable(true).ok());
  sim.advance_to(300.0);
  const auto after = board.casing_sensor.read();
  REQUIRE(after.valid);
  CHECK(after.time_s == 300.0);
  CHECK(after.temp_c > before.temp_c + 2.0);
  CHECK(after.temp_c == Approx(sim.plant().sensor_c()).margin(1.0 / 32.0));  // 1/16 C steps
}

TEST_CASE("the ambient sensor reads the chamber") {
  SimBoard sim{params_at(20.0), 1};
  Board board = sim.board();
  REQUIRE(board.ambient_sensor != nullptr);
  sim.set_ambient_c(-10.0);
  sim.advance_to(1.0);
  const auto reading = board.ambient_sensor->read();
  REQUIRE(reading.valid);
  CHECK(reading.temp_c == -10.0);
}

TEST_CASE("injected sensor faults reach the controller as typed faults") {
  SimBoard sim{params_at(25.0), 1};
  Board board = sim.board();
  sim.inject_casing_sensor_fault(SimTempFault::disconnect);
  CHECK(board.casing_sensor.read().fault == TempFault::missing_device);
  sim.inject_casing_sensor_fault(SimTempFault::crc_error);
  CHECK(board.casing_sensor.read().fault == TempFault::crc);
  sim.inject_casing_sensor_fault(SimTempFault::power_on_reset);
  CHECK(board.casing_sensor.read().fault == TempFault::power_on_value);
  sim.inject_casing_sensor_fault(SimTempFault::all_zero);
  CHECK(board.casing_sensor.read().fault == TempFault::all_zero);
  sim.inject_casing_sensor_fault(SimTempFault::none);
  CHECK(board.casing_sensor.read().valid);
}

TEST_CASE("an injected stuck sensor freezes while the casing warms") {
  SimBoard sim{params_at(25.0), 1};
  Board board = sim.board();
  const double frozen_c = board.casing_sensor.read().temp_c;
  sim.inject_casing_sensor_fault(SimTempFault::stuck);
  REQUIRE(board.tec.set_current_a(1.0).ok());
  REQUIRE(board.tec.enable(true).ok());
  sim.advance_to(300.0);
  CHECK(board.casing_sensor.read().temp_c == frozen_c);
  CHECK(sim.plant().sensor_c() > frozen_c + 1.0);
}

TEST_CASE("an injected DRDY stall and SPI error make ADC reads fail") {
  for (const SimAdcModel model : {SimAdcModel::bit_level, SimAdcModel::transaction}) {
    CAPTURE(static_cast<int>(model));
    SimBoardOptions options;
    options.adc_model = model;
    SimBoard sim{params_at(25.0), 1, options};
    Board board = sim.board();
    sim.inject_drdy_stall(true);
    const auto stalled = board.adc.read(0.01);
    REQUIRE_FALSE(stalled.ok());
    CHECK(stalled.error().code() == ErrorCode::timeout);
    CHECK(board.clock.now_s() == Approx(0.01));
    sim.inject_drdy_stall(false);
    sim.inject_spi_error(true);
    const auto broken = board.adc.read(0.01);
    REQUIRE_FALSE(broken.ok());
    CHECK(broken.error().code() == ErrorCode::io);
    sim.inject_spi_error(false);
    CHECK(board.adc.read(0.01).ok());
  }
}

TEST_CASE("lockstep, instant reader: the transaction-level ADC gives the bit-level path's samples, clock and plant") {
  SimBoardOptions bit_options;
  SimBoardOptions transaction_options;
  transaction_options.adc_model = SimAdcModel::transaction;
  SimBoard bit_sim{params_at(20.0), 11, bit_options};
  SimBoard transaction_sim{params_at(20.0), 11, transaction_options};
  Board bit = bit_sim.board();
  Board transaction = transaction_sim.board();
  for (Board* b : {&bit, &transaction}) {
    REQUIRE(b->tec.enable(true).ok());
  }
  int compared = 0;
  for (int i = 0; i < 20000; ++i) {
    if (i % 700 == 0) {  // the TEC current changes: plant steps between the two must fall alike
      const double current_a = 0.9 * std::sin(0.37 * i);
      REQUIRE(bit.tec.set_current_a(current_a).ok());
      REQUIRE(transaction.tec.set_current_a(current_a).ok());
    }
    if (i == 5000) {  // the clock moved past a stretch of conversions, unread
      bit_sim.advance_to(bit.clock.now_s() + 0.0503);
      transaction_sim.advance_to(transaction.clock.now_s() + 0.0503);
    }
    const auto a = bit.adc.read(0.01);
    const auto b = transaction.adc.read(0.01);
    REQUIRE(a.ok());
    REQUIRE(b.ok());
    REQUIRE(a->time_s == b->time_s);
    REQUIRE(a->code == b->code);
    REQUIRE(a->gyro_mv == b->gyro_mv);
    REQUIRE(a->clipped == b->clipped);
    REQUIRE(bit.clock.now_s() == transaction.clock.now_s());
    REQUIRE(bit_sim.plant().casing_c() == transaction_sim.plant().casing_c());
    REQUIRE(bit_sim.plant().time_s() == transaction_sim.plant().time_s());
    ++compared;
  }
  CHECK(compared == 20000);
  CHECK(transaction_sim.accepted_samples() == 20000);
  CHECK(transaction_sim.accepted_corrupted_samples() == 0);
}

TEST_CASE("the transaction-level ADC is refused in real time and with a reader that has timing") {
  SimBoardOptions options;
  options.adc_model = SimAdcModel::transaction;
  options.realtime = true;
  CHECK_THROWS_AS((SimBoard{params_at(20.0), 1, options}), std::invalid_argument);
  options.realtime = false;
  options.adc_timing.wake_max_s = 50e-6;
  CHECK_THROWS_AS((SimBoard{params_at(20.0), 1, options}), std::invalid_argument);
}

TEST_CASE("an injected OPA548 thermal shutdown raises the flag and cuts the TEC current") {
  SimBoard sim{params_at(25.0), 1};
  Board board = sim.board();
  REQUIRE(board.tec.set_current_a(1.0).ok());
  REQUIRE(board.tec.enable(true).ok());
  sim.advance_to(1.0);
  CHECK(*board.tec.thermal_status() == ThermalStatus::clear);
  sim.inject_opa548_thermal_shutdown(true);
  sim.advance_to(2.0);
  CHECK(*board.tec.thermal_status() == ThermalStatus::shutdown);
  CHECK(sim.plant().tec_current_a() == 0.0);
  sim.inject_opa548_thermal_shutdown(false);
  sim.advance_to(3.0);
  CHECK(*board.tec.thermal_status() == ThermalStatus::clear);
  CHECK(sim.plant().tec_current_a() == Approx(1.0).margin(0.01));
}

TEST_CASE("the rate DAC output is what the simulator decoded") {
  SimBoard sim{params_at(25.0), 1};
  Board board = sim.board();
  REQUIRE(board.rate_dac.write_v(1.0).ok());
  CHECK(sim.rate_out_v() == Approx(1.0).margin(2.5 / 65536));
}

TEST_CASE("real time: the ADC paces samples on the monotonic clock") {
  SimBoard sim{params_at(25.0), 1, realtime()};
  Board board = sim.board();
  const auto first = board.adc.read(0.1);
  REQUIRE(first.ok());
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 50; ++i) REQUIRE(board.adc.read(0.1).ok());
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(elapsed_s >= 0.045);  // 50 conversions at 1 kSPS
  CHECK(elapsed_s < 5.0);
}

#if !defined(GYROTC_NO_GUEST_THREADS)  // see link.cmake
TEST_CASE("real time: a DS18B20 read on another thread takes a conversion time without stalling the ADC") {
  SimBoard sim{params_at(25.0), 1, realtime()};
  Board board = sim.board();
  TemperatureReading reading;
  double sensor_s = 0.0;
  std::atomic<bool> sensor_done{false};
  std::thread sensor_thread([&] {
    const auto start = std::chrono::steady_clock::now();
    reading = board.casing_sensor.read();
    sensor_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    sensor_done.store(true);
  });
  // ADC conversions completed while the sensor read was in progress. A read
  // that held the board's lock would let none through; at 1 kSPS about 750
  // fit in the conversion time, and 50 leave room for a loaded machine.
  int samples = 0;
  while (!sensor_done.load()) {
    if (board.adc.read(0.1).ok() && !sensor_done.load()) ++samples;
  }
  sensor_thread.join();
  CHECK(sensor_s >= SimDs18b20::kConversionS);
  CHECK(reading.valid);
  CHECK(reading.temp_c == Approx(25.0).margin(0.07));
  CHECK(samples >= 50);
}
#endif
