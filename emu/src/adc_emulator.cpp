#include "gyrotc/emu/adc_emulator.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>

namespace gyrotc::emu {

namespace {
hal::SimAds1251::Config chip_config(const hal::Ads1251Config& config, hal::SimAds1251::PinListener* pin) {
  // The reader's timing is the real kernel's: no simulated latency.
  return {.fclk_hz = config.fclk_hz, .vref_v = config.vref_v, .request = hal::SimAds1251::EdgeRequest::falling,
          .timing = {}, .pin_listener = pin};
}
}  // namespace

AdcEmulator::AdcEmulator(hal::SimAds1251::Input& input, hal::Clock& clock, const hal::Ads1251Config& config,
                         PinOutput& pin, bool pin_active_low, EventLog& log)
    : clock_(clock),
      pin_(pin),
      pin_active_low_(pin_active_low),
      log_(log),
      chip_(input, clock, chip_config(config, this)) {
  // The part's idle level (DRDY mode, HIGH) before the first conversion.
  pin_.set_level(!pin_active_low_);
}

AdcEmulator::~AdcEmulator() { stop(); }

void AdcEmulator::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
}

void AdcEmulator::stop() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
}

double AdcEmulator::step() {
  const std::lock_guard lock(mutex_);
  return chip_.run_pin();
}

void AdcEmulator::run() {
  while (running_.load()) {
    const double next_s = step();
    // Wake for the pin's next change; at least every 50 ms to see a stop.
    clock_.sleep_until(std::min(next_s, clock_.now_s() + 0.05));
  }
}

void AdcEmulator::on_pin_level(bool high, double t_s) noexcept {
  const double start_s = clock_.now_s();
  pin_.set_level(high != pin_active_low_);
  // The pin falls, and the kernel stamps it, somewhere inside the write:
  // a slow one makes the emulated part's edge uncertain by its length, which
  // the configuration's stamp_latency_max_s has to cover. The slowest are logged.
  const double done_s = clock_.now_s();
  if (!high && done_s - start_s > kSlowPinWriteS) {
    char detail[96];
    std::snprintf(detail, sizeof detail, "write_ms=%.2f;after_its_time_ms=%.2f", (done_s - start_s) * 1e3,
                  (start_s - t_s) * 1e3);
    log_.add(done_s, "adc", "pin_write", "slow", detail);
  }
}

int AdcEmulator::transfer(const SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) {
  if (spi_error_.load()) return EIO;  // the controller reports the transfer failed
  const std::lock_guard lock(mutex_);
  // The ADS1251 has no chip select: an active-high CS changes nothing for it.
  if (const hal::Status s = chip_.spi().configure({.mode = wire.mode, .speed_hz = wire.speed_hz, .bits_per_word = 8});
      !s) {
    return EINVAL;
  }
  const std::uint64_t corrupted_before = chip_.counters().corrupted_reads;
  if (!chip_.spi().transfer(tx, rx)) return EIO;
  last_transfer_corrupted_ = chip_.counters().corrupted_reads != corrupted_before;
  if (last_transfer_corrupted_) {
    // When the first SCLK came, in tCLK after the conversion's DRDY edge:
    // DOUT mode is 12 .. 360.
    const hal::SimAds1251::TransferTiming t = chip_.last_transfer();
    char detail[96];
    std::snprintf(detail, sizeof detail, "mode=%u;bytes=%zu;start_tclk=%.1f", wire.mode, rx.size(),
                  (t.start_s - t.edge_s) / chip_.tclk_s());
    log_.add(clock_.now_s(), "adc", "transfer", "corrupted", detail);
  }
  return 0;
}

void AdcEmulator::set_drdy_stall(bool on) {
  const std::lock_guard lock(mutex_);
  chip_.set_drdy_stall(on);
}

void AdcEmulator::note_sample_used() {
  const std::lock_guard lock(mutex_);
  if (last_transfer_corrupted_) {
    ++corrupted_then_used_;
    log_.add(clock_.now_s(), "adc", "corrupted_sample", "used", "a rate-DAC frame followed a corrupted transfer");
  }
  last_transfer_corrupted_ = false;
}

AdcEmulator::Stats AdcEmulator::stats() const {
  const std::lock_guard lock(mutex_);
  return {chip_.counters(), corrupted_then_used_};
}

}  // namespace gyrotc::emu
