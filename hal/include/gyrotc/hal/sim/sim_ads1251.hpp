#pragma once

#include <atomic>
#include <cstdint>

#include "gyrotc/hal/clock.hpp"
#include "gyrotc/hal/gpio_line.hpp"
#include "gyrotc/hal/spi_bus.hpp"

namespace gyrotc::hal {

// Bit-level ADS1251 simulator: converts its analog input every 384 fCLK
// periods (conversion k completes at t = k * 384 / fCLK), announces it with a
// falling DRDY edge and shifts the 24-bit two's complement code out MSB first
// on SPI mode 0. A read later than the DOUT window (348 / fCLK after the
// edge) returns a mix of two conversions, as the real part does.
//
// Waiting for DRDY sleeps on the board's clock until the edge: a
// VirtualClock jumps there (lockstep), a RealtimeSimClock really waits. The
// per-sample path (edge wait, 3-byte transfer) does no allocation, no
// locking and no system call in lockstep mode.
class SimAds1251 {
 public:
  // The analog input: the gyro voltage of the conversion ending at t_s.
  class Input {
   public:
    virtual ~Input() = default;
    virtual double input_mv(double t_s) noexcept = 0;
  };

  struct Config {
    double fclk_hz = 384'000.0;
    double vref_v = 2.5;
  };

  SimAds1251(Input& input, Clock& clock, const Config& config) noexcept;
  SimAds1251(const SimAds1251&) = delete;
  SimAds1251& operator=(const SimAds1251&) = delete;

  SpiBus& spi() noexcept { return spi_; }
  GpioLine& drdy() noexcept { return drdy_; }

  // The code the converter produces for an input (rounded, clipped).
  std::int32_t code_for_mv(double mv) const noexcept;
  double sample_period_s() const noexcept { return period_s_; }

  // Fault injection (any thread): DRDY never falls; every SPI transfer fails.
  void set_drdy_stall(bool on) noexcept { stall_.store(on, std::memory_order_relaxed); }
  void set_spi_error(bool on) noexcept { spi_error_.store(on, std::memory_order_relaxed); }

  std::uint64_t conversions_read() const noexcept { return reads_; }
  std::uint64_t late_reads() const noexcept { return late_reads_; }

 private:
  class Bus final : public SpiBus {
   public:
    explicit Bus(SimAds1251& chip) noexcept : chip_(chip) {}

   private:
    Status do_configure(const SpiConfig& config) noexcept override;
    Status do_transfer(std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) noexcept override;
    std::string_view do_name() const noexcept override { return "sim:ads1251"; }
    SimAds1251& chip_;
  };
  class Drdy final : public GpioLine {
   public:
    explicit Drdy(SimAds1251& chip) noexcept : chip_(chip) {}

   private:
    Status do_set(bool high) noexcept override;
    Result<bool> do_get() noexcept override;
    Result<double> do_wait_edge(Edge edge, double timeout_s) noexcept override;
    std::string_view do_name() const noexcept override { return "sim:ads1251-drdy"; }
    SimAds1251& chip_;
  };

  Input& input_;
  Clock& clock_;
  Config config_;
  double period_s_;
  double window_s_;
  double codes_per_mv_;
  Bus spi_{*this};
  Drdy drdy_{*this};
  std::uint8_t spi_mode_ = 0xFF;  // not configured
  std::int64_t last_index_ = 0;   // conversion k of the last DRDY edge
  double edge_time_s_ = 0.0;
  std::uint32_t frame_ = 0;
  bool data_ready_ = false;
  std::uint64_t reads_ = 0;
  std::uint64_t late_reads_ = 0;
  std::atomic<bool> stall_{false};
  std::atomic<bool> spi_error_{false};
};

}  // namespace gyrotc::hal
