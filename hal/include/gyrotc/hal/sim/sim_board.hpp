#pragma once

#include <atomic>
#include <cstdint>
#include <memory>

#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/hal/board.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"
#include "gyrotc/hal/chips/ads1251.hpp"
#include "gyrotc/hal/chips/ds18b20.hpp"
#include "gyrotc/hal/chips/opa548.hpp"
#include "gyrotc/hal/chips/tec_stage.hpp"
#include "gyrotc/hal/linux/monotonic_clock.hpp"
#include "gyrotc/hal/sim/sim_ad5060.hpp"
#include "gyrotc/hal/sim/sim_ads1251.hpp"
#include "gyrotc/hal/sim/sim_ds18b20.hpp"
#include "gyrotc/hal/sim/sim_opa548.hpp"
#include "gyrotc/hal/sim/virtual_clock.hpp"

namespace gyrotc::hal {

// How the simulated board delivers the rate ADC's samples.
enum class SimAdcModel : std::uint8_t {
  // The Ads1251 driver over the bit-level SimAds1251: every pin edge and
  // timing window, each sample checked against its conversion (CheckedAdc).
  // Any reader timing, either clock.
  bit_level,
  // Lockstep with an instant reader only (adc_timing all zero): each
  // conversion's code handed over at its DRDY edge, the clock moved as the
  // driver's read of it moves it (to the edge, the hold-off, 24 SCLKs).
  // There the driver reads every conversion whole, so this is the bit-level
  // path's result sample for sample (tests/hal/sim/sim_board_test.cpp) at
  // under a third of its cost. A conversion the clock was moved past unread is
  // converted and missed (bit_level may still read the last one if its DOUT
  // window is open); an injected DRDY stall times out, an SPI fault fails the
  // read, as there.
  transaction,
};

struct SimBoardOptions {
  // false: lockstep (virtual time, single thread); true: real time.
  bool realtime = false;
  // The plant is advanced when the clock has moved this far past its last
  // advance, not per ADC sample (the plant integrates its thermal network on
  // steps of at most PlantParams::max_thermal_step_s).
  double thermal_step_s = 0.1;
  Ads1251Config adc;             // fclk_hz sets the sample rate (fclk/384)
  Ad5060Config rate_dac;
  // The TEC DAC's reference and the stage gain come from the plant
  // (PlantParams), so driver and simulated hardware agree; this is the
  // software current limit of the TecStage driver.
  double tec_current_limit_a = 1.5;
  Ds18b20Options sensor;
  bool ambient_sensor = true;    // a second DS18B20 outside the casing
  bool opa548_sense = true;      // a GPIO reads the OPA548's E/S pin (es_sense)
  // How late es_sense follows the pin: the board's two optocouplers and their
  // pull-ups (docs/BOARD-rpi4.md), a slow phototransistor's rise with a weak
  // pull-up taken at its worst, 1 ms (the virtual board's emulated line, a
  // gpio-sim write under TCG: up to 40 ms).
  double opa548_sense_delay_s = 0.001;
  // The ADS1251 reader's environment: DRDY edge to wake-up, IRQ delivery,
  // SPI start and return (SimAds1251::Timing, seeded from the board's seed).
  // The chip itself is always as hostile as the part; by default the reader
  // is instant (what `gyrotc simulate` studies is the thermal loop). The
  // daemon's [sim] table defaults to a PREEMPT_RT Raspberry Pi 4's typical
  // figures (app::SimConfig); real-time mode adds the host's own latency.
  SimAds1251::Timing adc_timing;
  SimAdcModel adc_model = SimAdcModel::bit_level;  // transaction: lockstep, instant reader only
};

// The simulated board: the same chip drivers as on the real board, over
// bit-level chip simulators wired to the plant model.
//
//   Ads1251 driver <- SimAds1251 (DRDY/DOUT pin + SPI) <- plant.gyro_mv()
//     every sample the driver returns is checked against the conversion it
//     claims to be (accepted_corrupted_samples())
//   Ad5060 #1 (rate out) -> SimAd5060 -> rate_out_v()
//   TecStage -> Ad5060 #2 -> SimAd5060 -> plant.set_tec_drive_v()
//            -> Opa548   -> SimOpa548 E/S  -> plant.set_tec_enabled()
//                           (E/S read back only with opa548_sense)
//   Ds18b20 drivers <- SimDs18b20 (w1_therm text) <- plant casing/ambient temperatures
//
// Time. The board's clock tells the board whenever it moves (ClockListener);
// the board then steps the plant in steps of at most thermal_step_s up to the
// new time. Waiting for DRDY moves the clock to the next conversion.
//  - Lockstep (realtime = false): a VirtualClock; everything runs on the
//    caller's thread, as fast as the CPU allows. The per-sample path (DRDY
//    wait, 3-byte SPI transfer, decode, rate DAC frame) is a handful of
//    virtual calls: no allocation, no lock, no system call. DS18B20 reads
//    return at once with the temperature at the current time: the lockstep
//    runner schedules conversion delays itself.
//  - Real time (realtime = true): a RealtimeSimClock (CLOCK_MONOTONIC, board
//    time 0 at construction). The ADC paces samples: the DRDY wait sleeps
//    (clock_nanosleep, absolute) until the next conversion. Only the thread
//    that calls the ADC, the DACs, the TEC driver and the clock's
//    sleep_until (the real-time thread) touches the plant. After every plant
//    step the board publishes the casing and ambient temperatures and the
//    OPA548 thermal state through relaxed atomics; a DS18B20 read() from a
//    non-real-time thread loads them, sleeps the 750 ms conversion on its own
//    clock and never blocks the real-time thread (no locks anywhere).
//    set_ambient_c(), set_rate_dps() and the fault injectors may be called
//    from any thread: they store atomics that the next plant step applies.
class SimBoard final : ClockListener, SimAds1251::Input, SimAd5060::Listener, SimOpa548::Listener {
 public:
  SimBoard(const model::PlantParams& params, std::uint64_t seed, const SimBoardOptions& options = {});
  ~SimBoard() override;
  SimBoard(const SimBoard&) = delete;
  SimBoard& operator=(const SimBoard&) = delete;

  Board board() noexcept;
  // Lockstep only (or from the real-time thread).
  model::Plant& plant() noexcept { return plant_; }

  // Any thread; applied at the next plant step.
  void set_ambient_c(double temp_c) noexcept { ambient_c_.store(temp_c, std::memory_order_relaxed); }
  void set_rate_dps(double rate_dps) noexcept { rate_dps_.store(rate_dps, std::memory_order_relaxed); }
  // Moves the clock to t_s (lockstep) and steps the plant up to it.
  void advance_to(double t_s) noexcept;

  // Fault injection (any thread).
  void inject_casing_sensor_fault(SimTempFault fault) noexcept { casing_chip_.set_fault(fault); }
  void inject_ambient_sensor_fault(SimTempFault fault) noexcept { ambient_chip_.set_fault(fault); }
  void inject_drdy_stall(bool on) noexcept { adc_chip_.set_drdy_stall(on); }
  void inject_spi_error(bool on) noexcept { adc_chip_.set_spi_error(on); }
  void inject_rate_dac_spi_error(bool on) noexcept { rate_dac_chip_.set_spi_error(on); }
  void inject_tec_dac_spi_error(bool on) noexcept { tec_dac_chip_.set_spi_error(on); }
  void inject_opa548_thermal_shutdown(bool on) noexcept { opa548_chip_.inject_thermal_shutdown(on); }

  // What the simulated hardware shows (any thread).
  double rate_out_v() const noexcept { return rate_dac_chip_.output_v(); }
  double published_casing_c() const noexcept { return casing_chip_.temperature_c(); }
  double published_ambient_c() const noexcept { return ambient_chip_.temperature_c(); }
  const SimAds1251& adc_chip() const noexcept { return adc_chip_; }
  const SimAd5060& rate_dac_chip() const noexcept { return rate_dac_chip_; }
  const SimAd5060& tec_dac_chip() const noexcept { return tec_dac_chip_; }
  const SimOpa548& opa548_chip() const noexcept { return opa548_chip_; }
  const SimBoardOptions& options() const noexcept { return options_; }
  // ADC samples the driver returned, and those whose code is not the code of
  // the conversion their time stamp names (a mixed, shifted or zero read the
  // driver took for good). Any thread.
  std::uint64_t accepted_samples() const noexcept {
    return checked_adc_.accepted() + transaction_adc_.accepted();
  }
  std::uint64_t accepted_corrupted_samples() const noexcept { return checked_adc_.corrupted(); }

 private:
  // The Board's rate ADC: the Ads1251 driver, each sample checked against
  // the simulator's record of what the conversion was.
  class CheckedAdc final : public RateAdc {
   public:
    CheckedAdc(RateAdc& driver, const SimAds1251& chip) noexcept : driver_(driver), chip_(chip) {}
    std::uint64_t accepted() const noexcept { return accepted_.load(std::memory_order_relaxed); }
    std::uint64_t corrupted() const noexcept { return corrupted_.load(std::memory_order_relaxed); }

   private:
    Result<AdcSample> do_read(double timeout_s) noexcept override;
    AdcReadStats do_stats() const noexcept override { return driver_.stats(); }
    RateAdc& driver_;
    const SimAds1251& chip_;
    std::atomic<std::uint64_t> accepted_{0};
    std::atomic<std::uint64_t> corrupted_{0};
  };

  // SimAdcModel::transaction (see there).
  class TransactionAdc final : public RateAdc {
   public:
    explicit TransactionAdc(SimBoard& board) noexcept;
    std::uint64_t accepted() const noexcept { return accepted_.load(std::memory_order_relaxed); }

   private:
    Result<AdcSample> do_read(double timeout_s) noexcept override;
    AdcReadStats do_stats() const noexcept override { return stats_; }
    double edge_s(std::int64_t k) const noexcept { return static_cast<double>(k) * period_s_; }
    SimBoard& board_;
    double period_s_;
    double hold_off_s_;   // the driver's: DOUT mode starts 12 tCLK after the edge, then t6
    double bit_s_;        // one SCLK at the configured speed
    std::int64_t next_k_; // the next conversion (DRDY edge at next_k_ * period_s_)
    bool have_read_ = false;
    AdcReadStats stats_;
    std::atomic<std::uint64_t> accepted_{0};
  };

  void on_time_advanced(double now_s) noexcept override;
  double input_mv(double t_s) noexcept override;
  void on_dac_output(double output_v, Ad5060PowerDown mode) noexcept override;
  void on_opa548_drive(bool released) noexcept override;
  void step_plant_to(double t_s) noexcept;
  void publish() noexcept;
  void apply_tec_enable() noexcept;

  SimBoardOptions options_;
  model::Plant plant_;
  std::atomic<double> ambient_c_;
  std::atomic<double> rate_dps_{0.0};
  double next_step_s_ = 0.0;  // the clock time at which the plant is due a step

  VirtualClock virtual_clock_;
  RealtimeSimClock realtime_clock_;
  MonotonicClock sensor_sleep_clock_;
  Clock& clock_;

  SimAds1251 adc_chip_;
  SimAd5060 rate_dac_chip_;
  SimAd5060 tec_dac_chip_;
  SimOpa548 opa548_chip_;
  SimDs18b20 casing_chip_;
  SimDs18b20 ambient_chip_;

  Ads1251 adc_;
  CheckedAdc checked_adc_;
  TransactionAdc transaction_adc_;
  Ad5060 rate_dac_;
  Ad5060 tec_dac_;
  Opa548 opa548_;
  TecStage tec_;
  Ds18b20 casing_;
  Ds18b20 ambient_;
};

}  // namespace gyrotc::hal
