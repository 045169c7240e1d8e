#include "gyrotc/hal/sim/sim_board.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace gyrotc::hal {

namespace {
constexpr const char* kCasingId = "28-00000000ca51";   // simulated w1 ids
constexpr const char* kAmbientId = "28-00000000a4b1";

SimAds1251::Config adc_chip_config(const SimBoardOptions& options, std::uint64_t seed) {
  SimAds1251::Config config{.fclk_hz = options.adc.fclk_hz, .vref_v = options.adc.vref_v,
                            .request = SimAds1251::EdgeRequest::falling, .timing = options.adc_timing};
  config.timing.seed ^= seed * 0x9E3779B97F4A7C15ULL + 0xADC;  // its own stream, not the plant's
  return config;
}

bool instant(const SimAds1251::Timing& t) noexcept {
  return t.wake_min_s == 0.0 && t.wake_max_s == 0.0 && t.stall_probability == 0.0 && t.irq_delay_max_s == 0.0 &&
         t.stamp_delay_max_s == 0.0 && t.late_stamp_probability == 0.0 && t.spi_start_max_s == 0.0 &&
         t.spi_return_max_s == 0.0;
}

const SimBoardOptions& checked(const SimBoardOptions& options) {
  if (options.adc_model == SimAdcModel::transaction && (options.realtime || !instant(options.adc_timing))) {
    throw std::invalid_argument(
        "SimBoard: the transaction-level ADC is for lockstep runs with an instant reader (adc_timing all zero)");
  }
  return options;
}
}  // namespace

SimBoard::SimBoard(const model::PlantParams& params, std::uint64_t seed, const SimBoardOptions& options)
    : options_(checked(options)),
      plant_(params, seed),
      ambient_c_(plant_.ambient_c()),
      next_step_s_(options.thermal_step_s),
      clock_(options.realtime ? static_cast<Clock&>(realtime_clock_) : static_cast<Clock&>(virtual_clock_)),
      adc_chip_(*this, clock_, adc_chip_config(options, seed)),
      rate_dac_chip_("sim:ad5060-rate", options.rate_dac.vref_v),
      tec_dac_chip_("sim:ad5060-tec", params.dac_vref_v, this),
      opa548_chip_(this, &clock_, options.opa548_sense_delay_s),
      casing_chip_(kCasingId, plant_.sensor_c(), options.realtime ? &sensor_sleep_clock_ : nullptr),
      ambient_chip_(kAmbientId, plant_.ambient_sensor_c(), options.realtime ? &sensor_sleep_clock_ : nullptr),
      adc_(adc_chip_.spi(), adc_chip_.drdy(), clock_, options.adc),
      checked_adc_(adc_, adc_chip_),
      transaction_adc_(*this),
      rate_dac_(rate_dac_chip_, options.rate_dac),
      tec_dac_(tec_dac_chip_, {.vref_v = params.dac_vref_v}),
      opa548_(opa548_chip_.es_drive(), options.opa548_sense ? &opa548_chip_.es_sense() : nullptr),
      tec_(tec_dac_, opa548_, {.gain_a_per_v = params.gain_a_per_v, .current_limit_a = options.tec_current_limit_a}),
      casing_(casing_chip_, clock_, options.sensor),
      ambient_(ambient_chip_, clock_, options.sensor) {
  virtual_clock_.set_listener(this);
  realtime_clock_.set_listener(this);
  // The same bring-up as the real board: TEC at 0 A and OPA548 off, rate
  // output at mid-scale. The drivers were validated by the config parser;
  // the simulators accept these bus settings.
  (void)adc_.init();
  (void)rate_dac_.init();
  (void)tec_dac_.init();
  (void)tec_.safe_off();
  (void)rate_dac_.write_v(options.rate_dac.vref_v / 2.0);
  publish();
}

SimBoard::~SimBoard() { (void)tec_.safe_off(); }

Board SimBoard::board() noexcept {
  RateAdc& adc = options_.adc_model == SimAdcModel::transaction ? static_cast<RateAdc&>(transaction_adc_)
                                                                  : static_cast<RateAdc&>(checked_adc_);
  return {adc, casing_, options_.ambient_sensor ? &ambient_ : nullptr, rate_dac_, tec_, clock_};
}

SimBoard::TransactionAdc::TransactionAdc(SimBoard& board) noexcept
    : board_(board),
      period_s_(board.adc_chip_.sample_period_s()),
      hold_off_s_(Ads1251::kHoldOffClocks / board.options_.adc.fclk_hz + Ads1251::kHoldOffExtraS),
      bit_s_(1.0 / board.options_.adc.spi_speed_hz),
      // The chip's first DRDY edge: the first conversion boundary after now.
      next_k_(static_cast<std::int64_t>(std::floor(board.clock_.now_s() / period_s_)) + 1) {}

// Each step is the bit-level path's, in its order: the chip converts at the
// DRDY boundary before the clock reaches it (input_mv, the plant's noise
// draw), the reader wakes at the edge, sleeps the hold-off, clocks 24 bits.
Result<AdcSample> SimBoard::TransactionAdc::do_read(double timeout_s) noexcept {
  VirtualClock& clock = board_.virtual_clock_;  // lockstep only (final: the calls are direct)
  const double now_s = clock.now_s();
  const double deadline_s = now_s + std::max(timeout_s, 0.0);
  // Conversions the clock was moved past: converted, never read.
  for (; edge_s(next_k_) <= now_s; ++next_k_) {
    (void)board_.input_mv(edge_s(next_k_));
    if (have_read_) ++stats_.missed_conversions;
  }
  if (board_.adc_chip_.drdy_stalled() || edge_s(next_k_) > deadline_s) {
    for (; edge_s(next_k_) <= deadline_s; ++next_k_) (void)board_.input_mv(edge_s(next_k_));
    clock.sleep_until(deadline_s);
    return Error::make(ErrorCode::timeout, "sim:ads1251: no DRDY falling edge within %.3f s", timeout_s);
  }
  const double edge = edge_s(next_k_);
  ++next_k_;
  const std::int32_t code = board_.adc_chip_.code_for_mv(board_.input_mv(edge));
  clock.sleep_until(edge);
  clock.sleep_until(edge + hold_off_s_);
  if (board_.adc_chip_.spi_failing()) {
    return Error::make(ErrorCode::io, "sim:ads1251: SPI transfer failed (injected fault)");
  }
  clock.sleep_until(clock.now_s() + 24.0 * bit_s_);
  AdcSample sample;
  sample.code = code;
  sample.clipped = code >= Ads1251::kCodeMax || code <= Ads1251::kCodeMin;
  sample.gyro_mv = board_.adc_.code_to_mv(code);
  sample.time_s = edge;
  have_read_ = true;
  accepted_.store(accepted_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  return sample;
}

Result<AdcSample> SimBoard::CheckedAdc::do_read(double timeout_s) noexcept {
  Result<AdcSample> sample = driver_.read(timeout_s);
  if (!sample) return sample;
  const auto k = static_cast<std::int64_t>(sample->time_s / chip_.sample_period_s() + 0.5);  // stamps are > 0
  const std::optional<std::int32_t> truth = chip_.code_of_conversion(k);
  accepted_.store(accepted_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  if (!truth || *truth != sample->code) {
    corrupted_.store(corrupted_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  }
  return sample;
}

void SimBoard::advance_to(double t_s) noexcept {
  if (options_.realtime) {
    clock_.sleep_until(t_s);  // the listener steps the plant
  } else if (t_s > virtual_clock_.now_s()) {
    virtual_clock_.sleep_until(t_s);
  } else {
    step_plant_to(t_s);
  }
}

void SimBoard::on_time_advanced(double now_s) noexcept {
  if (now_s >= next_step_s_) step_plant_to(now_s);
}

void SimBoard::step_plant_to(double t_s) noexcept {
  const double span_s = t_s - plant_.time_s();
  if (span_s > 0.0) {
    plant_.set_ambient_c(ambient_c_.load(std::memory_order_relaxed));
    plant_.set_rate_dps(rate_dps_.load(std::memory_order_relaxed));
    apply_tec_enable();
    plant_.advance(span_s);
    publish();
  }
  next_step_s_ = t_s + options_.thermal_step_s;
}

void SimBoard::publish() noexcept {
  casing_chip_.set_temperature_c(plant_.sensor_c());
  ambient_chip_.set_temperature_c(plant_.ambient_sensor_c());
  opa548_chip_.set_thermal_shutdown(plant_.opa548_thermal_shutdown());
}

// The plant models the die's own thermal shutdown; an injected one is ours.
void SimBoard::apply_tec_enable() noexcept {
  plant_.set_tec_enabled(opa548_chip_.drive_released() && !opa548_chip_.injected_shutdown());
}

double SimBoard::input_mv(double) noexcept { return plant_.gyro_mv(adc_chip_.sample_period_s()); }

void SimBoard::on_dac_output(double output_v, Ad5060PowerDown) noexcept { plant_.set_tec_drive_v(output_v); }

void SimBoard::on_opa548_drive(bool) noexcept { apply_tec_enable(); }

}  // namespace gyrotc::hal
