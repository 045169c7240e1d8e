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
// open-drain output would read as disabled. Outputs are requested low.
Result<std::unique_ptr<GpiodLine>> request_line(const GpioRef& ref, GpioMode mode) {
  return GpiodLine::open({.chip = ref.chip, .line = ref.line, .mode = mode, .edge = Edge::falling,
                          .bias = ref.bias, .active_low = ref.active_low, .open_drain = false,
                          .initial_high = false});
}

std::unique_ptr<GpiodLine> open_line(const GpioRef& ref, GpioMode mode, DeviceErrors& errors) {
  return take(request_line(ref, mode), errors);
}

// The w1 device must exist now, and an empty id must name exactly one
// DS18B20 (a DS18B20 read takes 750 ms; probe reads it later through the
// board).
void check_w1(W1Sysfs& w1, const W1SensorConfig& config, DeviceErrors& errors) {
  if (config.id.empty()) {
    if (Status bound = w1.find_device(); !bound) errors.add(bound.error());
    return;
  }
  struct stat st {};
  if (::stat(w1.device_path().c_str(), &st) != 0) errors.add(Error::from_errno(errno, "no w1 device", w1.device_path()));
}

bool busy(const Result<std::unique_ptr<SpidevBus>>& bus) {
  return !bus && bus.error().code() == ErrorCode::busy;
}

}  // namespace

LinuxBoard::Opened LinuxBoard::open(const LinuxBoardConfig& config) {
  std::unique_ptr<LinuxBoard> b(new LinuxBoard());
  std::vector<DeviceFailure> failures;
  DeviceErrors adc{"adc", {}};
  DeviceErrors tec_dac{"tec_dac", {}};
  DeviceErrors opa{"opa548", {}};
  DeviceErrors rate{"rate_dac", {}};

  // 1. The SPI devices, each locked, before anything is written: a board
  //    another gyrotc holds is left exactly as it is.
  auto adc_spi = SpidevBus::open(config.adc_spi);
  auto tec_dac_spi = SpidevBus::open(config.tec_dac_spi);
  auto rate_dac_spi = SpidevBus::open(config.rate_dac_spi);
  const bool in_use = busy(adc_spi) || busy(tec_dac_spi) || busy(rate_dac_spi);
  b->adc_spi_ = take(std::move(adc_spi), adc);
  b->tec_dac_spi_ = take(std::move(tec_dac_spi), tec_dac);
  b->rate_dac_spi_ = take(std::move(rate_dac_spi), rate);
  if (in_use) {
    for (const DeviceErrors* e : {&adc, &tec_dac, &rate}) e->flush(failures);
    b.reset();  // nothing was requested or written: the destructor touches nothing
    return {nullptr, std::move(failures)};
  }

  // 2. The GPIO lines (E/S requested low: disabled) and the w1 devices.
  if (Status s = Ads1251::validate(config.adc); !s) adc.add(s.error());
  b->drdy_ = open_line(config.adc_drdy, GpioMode::edge_events, adc);
  b->es_drive_ = open_line(config.opa548_es, GpioMode::output, opa);
  if (config.opa548_es_sense) b->es_sense_ = open_line(*config.opa548_es_sense, GpioMode::input, opa);

  // 3. The safe state: TEC DAC at 0 A with the OPA548 disabled, rate DAC at mid-scale.
  if (b->adc_spi_ && b->drdy_) {
    b->adc_ = std::make_unique<Ads1251>(*b->adc_spi_, *b->drdy_, b->clock_, config.adc);
    if (Status s = b->adc_->init(); !s) adc.add(s.error());
  }
  if (b->tec_dac_spi_) b->tec_dac_ = std::make_unique<Ad5060>(*b->tec_dac_spi_, config.tec_dac);
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
  if (b->rate_dac_spi_) {
    b->rate_dac_ = std::make_unique<Ad5060>(*b->rate_dac_spi_, config.rate_dac);
    if (Status s = b->rate_dac_->init(); !s) rate.add(s.error());
    if (Status s = b->rate_dac_->write_v(config.rate_dac.vref_v / 2.0); !s) rate.add(s.error());
  }
  adc.flush(failures);
  tec_dac.flush(failures);
  opa.flush(failures);
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

SafeOffReport LinuxBoard::safe_off(const LinuxBoardConfig& config) {
  SafeOffReport report;
  auto tec_spi = SpidevBus::open(config.tec_dac_spi);
  auto rate_spi = SpidevBus::open(config.rate_dac_spi);
  const bool in_use = busy(tec_spi) || busy(rate_spi);
  if (in_use) {
    // Another gyrotc owns the board: leave it alone, and say who.
    const Error holder = busy(tec_spi) ? tec_spi.error() : rate_spi.error();
    return {holder, holder, holder};
  }
  auto es = request_line(config.opa548_es, GpioMode::output);  // requested low: disabled
  if (!es) report.opa548 = es.error();
  if (!tec_spi) {
    report.tec_dac = tec_spi.error();
  } else {
    Ad5060 dac(*tec_spi.value(), config.tec_dac);
    report.tec_dac = dac.init();
    if (report.tec_dac.ok() && es) {
      Opa548 amplifier(*es.value(), nullptr);
      TecStage tec(dac, amplifier, config.tec);
      const Status dac_first = tec.set_current_a(0.0);
      report.tec_dac = dac_first;
      report.opa548 = amplifier.enable(false);
    } else if (report.tec_dac.ok()) {
      report.tec_dac = dac.write_v(config.tec_dac.vref_v / 2.0);
    }
  }
  if (!rate_spi) {
    report.rate_dac = rate_spi.error();
  } else {
    Ad5060 rate(*rate_spi.value(), config.rate_dac);
    report.rate_dac = rate.init();
    if (report.rate_dac.ok()) report.rate_dac = rate.write_v(config.rate_dac.vref_v / 2.0);
  }
  return report;
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
