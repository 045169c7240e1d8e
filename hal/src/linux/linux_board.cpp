#include "gyrotc/hal/linux/linux_board.hpp"

#include <sys/stat.h>

#include <cerrno>

namespace gyrotc::hal {

namespace {

// Collects the errors of one device into one line.
struct DeviceErrors {
  std::string device;
  std::string message;
  void add(const Error& e) {
    if (!message.empty()) message += "; ";
    message += e.message();
  }
  void flush(std::vector<DeviceFailure>& failures) const {
    if (!message.empty()) failures.push_back({device, message});
  }
};

template <typename T>
std::unique_ptr<T> take(Result<std::unique_ptr<T>>&& result, DeviceErrors& errors) {
  if (!result) {
    errors.add(result.error());
    return nullptr;
  }
  return std::move(result.value());
}

// Push-pull throughout: the E/S drive must actively pull high to enable the
// OPA548 against its default-off pull-down (docs/BOARD-rpi4.md); a released
// open-drain output would read as disabled.
std::unique_ptr<GpiodLine> open_line(const GpioRef& ref, GpioMode mode, DeviceErrors& errors) {
  return take(GpiodLine::open({.chip = ref.chip, .line = ref.line, .mode = mode, .open_drain = false,
                               .initial_high = false}),
              errors);
}

// The w1 device must exist now (a DS18B20 read takes 750 ms; probe reads it
// later through the board).
void check_w1(const W1Sysfs& w1, const W1SensorConfig& config, DeviceErrors& errors) {
  struct stat st {};
  if (::stat(w1.device_path().c_str(), &st) == 0) return;
  if (config.id.empty()) {
    errors.add(Error::make(ErrorCode::not_found, "no DS18B20 (28-*) under '%s'", config.w1_root.c_str()));
  } else {
    errors.add(Error::from_errno(errno, "no w1 device", w1.device_path()));
  }
}

}  // namespace

LinuxBoard::Opened LinuxBoard::open(const LinuxBoardConfig& config) {
  std::unique_ptr<LinuxBoard> b(new LinuxBoard());
  std::vector<DeviceFailure> failures;

  DeviceErrors adc{"adc", {}};
  if (Status s = Ads1251::validate(config.adc); !s) adc.add(s.error());
  b->adc_spi_ = take(SpidevBus::open(config.adc_spi), adc);
  b->drdy_ = open_line(config.adc_drdy, GpioMode::edge_events, adc);
  if (b->adc_spi_ && b->drdy_) {
    b->adc_ = std::make_unique<Ads1251>(*b->adc_spi_, *b->drdy_, config.adc);
    if (Status s = b->adc_->init(); !s) adc.add(s.error());
  }
  adc.flush(failures);

  DeviceErrors tec_dac{"tec_dac", {}};
  b->tec_dac_spi_ = take(SpidevBus::open(config.tec_dac_spi), tec_dac);
  if (b->tec_dac_spi_) b->tec_dac_ = std::make_unique<Ad5060>(*b->tec_dac_spi_, config.tec_dac);
  DeviceErrors opa{"opa548", {}};
  b->es_drive_ = open_line(config.opa548_es, GpioMode::output, opa);  // requested low: disabled
  if (config.opa548_es_sense) b->es_sense_ = open_line(*config.opa548_es_sense, GpioMode::input, opa);
  if (b->es_drive_) b->opa548_ = std::make_unique<Opa548>(*b->es_drive_, b->es_sense_.get());
  if (b->tec_dac_ && b->opa548_) {
    b->tec_ = std::make_unique<TecStage>(*b->tec_dac_, *b->opa548_, config.tec);
    if (Status s = b->tec_dac_->init(); !s) tec_dac.add(s.error());
    if (Status s = b->tec_->safe_off(); !s) tec_dac.add(s.error());
  } else if (b->tec_dac_) {
    // No amplifier: still bring the DAC to 0 A (mid-scale).
    if (Status s = b->tec_dac_->init(); !s) tec_dac.add(s.error());
    if (Status s = b->tec_dac_->write_v(config.tec_dac.vref_v / 2.0); !s) tec_dac.add(s.error());
  }
  tec_dac.flush(failures);
  opa.flush(failures);

  DeviceErrors rate{"rate_dac", {}};
  b->rate_dac_spi_ = take(SpidevBus::open(config.rate_dac_spi), rate);
  if (b->rate_dac_spi_) {
    b->rate_dac_ = std::make_unique<Ad5060>(*b->rate_dac_spi_, config.rate_dac);
    if (Status s = b->rate_dac_->init(); !s) rate.add(s.error());
    if (Status s = b->rate_dac_->write_v(config.rate_dac.vref_v / 2.0); !s) rate.add(s.error());
  }
  rate.flush(failures);

  DeviceErrors casing{"casing_sensor", {}};
  b->casing_w1_ = std::make_unique<W1Sysfs>(config.casing_sensor.w1_root, config.casing_sensor.id);
  check_w1(*b->casing_w1_, config.casing_sensor, casing);
  b->casing_ = std::make_unique<Ds18b20>(*b->casing_w1_, b->clock_, config.casing_sensor.options);
  casing.flush(failures);
  if (config.ambient_sensor) {
    DeviceErrors ambient{"ambient_sensor", {}};
    b->ambient_w1_ = std::make_unique<W1Sysfs>(config.ambient_sensor->w1_root, config.ambient_sensor->id);
    check_w1(*b->ambient_w1_, *config.ambient_sensor, ambient);
    b->ambient_ = std::make_unique<Ds18b20>(*b->ambient_w1_, b->clock_, config.ambient_sensor->options);
    ambient.flush(failures);
  }

  if (!failures.empty()) b.reset();  // the destructor brings what was opened to its safe state
  return {std::move(b), std::move(failures)};
}

LinuxBoard::~LinuxBoard() {
  if (tec_) {
    (void)tec_->safe_off();
  } else if (opa548_) {
    (void)opa548_->enable(false);
  }
}

Board LinuxBoard::board() noexcept {
  return {*adc_, *casing_, ambient_.get(), *rate_dac_, *tec_, clock_};
}

}  // namespace gyrotc::hal
