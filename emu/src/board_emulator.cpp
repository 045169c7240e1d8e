#include "gyrotc/emu/board_emulator.hpp"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "gyrotc/app/formats/chamber_profile_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/emu/requester.hpp"
#include "gyrotc/hal/chips/ad5060.hpp"

namespace gyrotc::emu {

namespace {

const char* pd_name(hal::Ad5060PowerDown mode) {
  switch (mode) {
    case hal::Ad5060PowerDown::normal: return "normal";
    case hal::Ad5060PowerDown::gnd_1k: return "1k-to-gnd";
    case hal::Ad5060PowerDown::gnd_100k: return "100k-to-gnd";
    case hal::Ad5060PowerDown::three_state: return "three-state";
  }
  return "?";
}

std::optional<hal::SimTempFault> sensor_fault_named(const std::string& name) {
  if (name == "none") return hal::SimTempFault::none;
  if (name == "disconnect") return hal::SimTempFault::disconnect;
  if (name == "crc") return hal::SimTempFault::crc_error;
  if (name == "stuck") return hal::SimTempFault::stuck;
  if (name == "power-on-reset") return hal::SimTempFault::power_on_reset;
  if (name == "all-zero") return hal::SimTempFault::all_zero;
  if (name == "low-resolution") return hal::SimTempFault::low_resolution;
  return std::nullopt;
}

std::optional<bool> on_off(const std::string& word) {
  if (word == "on") return true;
  if (word == "off") return false;
  return std::nullopt;
}

std::optional<double> number(const std::string& word) {
  try {
    std::size_t used = 0;
    const double v = std::stod(word, &used);
    if (used != word.size() || !std::isfinite(v)) return std::nullopt;
    return v;
  } catch (...) {
    return std::nullopt;
  }
}

}  // namespace

std::string emulated_casing_id(const app::BoardConfig& board) {
  const std::string& id = board.devices.casing_sensor.id;
  return id.empty() ? "28-00000000ca51" : id;
}

std::string emulated_ambient_id(const app::BoardConfig& board) {
  if (!board.devices.ambient_sensor) return {};
  const std::string& id = board.devices.ambient_sensor->id;
  return id.empty() ? "28-00000000a4b1" : id;
}

// --- the DACs ------------------------------------------------------------------

BoardEmulator::Dac::Dac(BoardEmulator& board, std::string name, double vref_v, bool tec)
    : board_(board), name_(std::move(name)), tec_(tec), chip_("emu:" + name_, vref_v, this) {}

int BoardEmulator::Dac::transfer(const SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) {
  if (spi_error.load()) return EIO;
  std::fill(rx.begin(), rx.end(), std::uint8_t{0});
  // SPI_CS_HIGH: SYNC is high while the bits go by and falls after them: the
  // part never sees a frame.
  if (wire.cs_active_high) return 0;
  if (!chip_.configure({.mode = wire.mode, .speed_hz = wire.speed_hz, .bits_per_word = 8})) return EINVAL;
  latched_ = false;
  std::uint64_t ignored = chip_.ignored_frames();
  (void)chip_.transfer(tx, rx);
  if (!latched_ && chip_.ignored_frames() != ignored) {
    char detail[64];
    std::snprintf(detail, sizeof detail, "bytes=%zu;sclk_hz=%u", tx.size(), wire.speed_hz);
    board_.log_.add(board_.clock_.now_s(), "dac", name_, "ignored", detail);
  }
  if (latched_ && !tec_ && chip_.mode() == hal::Ad5060PowerDown::normal && chip_.code() != 32768) {
    board_.adc_.note_sample_used();
  }
  return 0;
}

void BoardEmulator::Dac::on_dac_output(double output_v, hal::Ad5060PowerDown mode) noexcept {
  latched_ = true;
  const double now_s = board_.clock_.now_s();
  board_.log_.add(now_s, "dac", name_, std::to_string(chip_.code()),
                  std::string("mode=") + pd_name(mode) + ";pid=" + std::to_string(requester_pid()));
  if (!tec_) return;
  const std::lock_guard lock(board_.mutex_);
  board_.plant_.set_tec_drive_v(output_v);
}

// --- the board -----------------------------------------------------------------

BoardEmulator::BoardEmulator(const EmulatorOptions& options, hal::Clock& clock, PinOutput& drdy, PinInput& es_drive,
                             PinOutput* es_sense, EventLog& log)
    : options_(options),
      clock_(clock),
      es_drive_(es_drive),
      es_sense_(es_sense),
      log_(log),
      start_s_(clock.now_s()),
      casing_id_(emulated_casing_id(options.board)),
      ambient_id_(emulated_ambient_id(options.board)),
      plant_((model::validate(options.plant), options.plant), options.seed),
      ambient_c_(options.plant.initial_temp_c),
      ambient_set_at_s_(start_s_),
      adc_(*this, clock, options.board.devices.adc, drdy, options.board.devices.adc_drdy.active_low, log),
      rate_dac_(*this, "rate_dac", options.board.devices.rate_dac.vref_v, false),
      tec_dac_(*this, "tec_dac", options.board.devices.tec_dac.vref_v, true) {
  const auto& d = options_.board.devices;
  std::map<std::string, std::vector<std::string>> ids;
  ids[d.casing_sensor.w1_root].push_back(casing_id_);
  if (d.ambient_sensor) ids[d.ambient_sensor->w1_root].push_back(ambient_id_);
  for (auto& [root, list] : ids) {
    buses_[root] = std::make_shared<W1Bus>(list, options_.plant.initial_temp_c, start_s_, options_.w1);
  }
  next_plant_log_s_ = start_s_;
  const std::lock_guard lock(mutex_);
  set_sense_locked();
  log_.add(start_s_, "emu", "start", "0",
           "casing=" + casing_id_ + (ambient_id_.empty() ? "" : ";ambient=" + ambient_id_));
}

BoardEmulator::~BoardEmulator() { stop(); }

void BoardEmulator::start() {
  if (running_.exchange(true)) return;
  adc_.start();
  plant_thread_ = std::thread([this] { run_plant(); });
  es_thread_ = std::thread([this] { run_es(); });
  // The chips' timing is the ADC pin's and the SPI nodes' (real-time when the
  // process is); the plant's 0.1 s steps and the E/S poll can wait their turn.
  for (std::thread* t : {&plant_thread_, &es_thread_}) {
    sched_param normal{};
    (void)pthread_setschedparam(t->native_handle(), SCHED_OTHER, &normal);
  }
}

void BoardEmulator::stop() {
  if (!running_.exchange(false)) return;
  adc_.stop();
  if (plant_thread_.joinable()) plant_thread_.join();
  if (es_thread_.joinable()) es_thread_.join();
  log_.flush();
}

double BoardEmulator::input_mv(double) noexcept {
  const std::lock_guard lock(mutex_);
  return plant_.gyro_mv(adc_.sample_period_s());
}

W1Bus* BoardEmulator::bus_of(const std::string& id) {
  for (auto& entry : buses_) {
    const auto& ids = entry.second->ids();
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) return entry.second.get();
  }
  return nullptr;
}

void BoardEmulator::set_sense_locked() {
  // E/S is high only while the drive releases it and the part is not in
  // thermal shutdown (it pulls E/S low itself then).
  const bool shutdown = injected_shutdown_ || plant_.opa548_thermal_shutdown();
  const bool pin_high = es_enabled_ && !shutdown;
  plant_.set_tec_enabled(es_enabled_ && !injected_shutdown_);
  if (es_sense_ == nullptr) return;
  const bool physical = pin_high != options_.board.devices.opa548_es_sense->active_low;
  if (sense_level_ != physical) {
    es_sense_->set_level(physical);
    sense_level_ = physical;
    log_.add(clock_.now_s(), "es", "sense", pin_high ? "1" : "0");
  }
}

void BoardEmulator::poll_es() {
  const std::optional<bool> level = es_drive_.level();
  // A line nobody drives reads its pull-down: disabled.
  const bool enabled = level.value_or(false) != options_.board.devices.opa548_es.active_low && level.has_value();
  const std::lock_guard lock(mutex_);
  if (enabled != es_enabled_) {
    es_enabled_ = enabled;
    log_.add(clock_.now_s(), "es", "drive", enabled ? "1" : "0");
  }
  set_sense_locked();
}

void BoardEmulator::step_plant() {
  const double now_s = clock_.now_s();
  const std::lock_guard lock(mutex_);
  const double t_s = now_s - start_s_;
  double ambient_c = ambient_c_ + ambient_ramp_c_per_s_ * (now_s - ambient_set_at_s_);
  if (chamber_) ambient_c = chamber_->ambient_c(now_s - chamber_start_s_);
  plant_.set_ambient_c(ambient_c);
  plant_.set_rate_dps(rate_dps_);
  if (t_s > plant_.time_s()) plant_.advance(t_s - plant_.time_s());
  if (W1Bus* bus = bus_of(casing_id_)) bus->set_temperature_c(casing_id_, plant_.sensor_c());
  if (W1Bus* bus = ambient_id_.empty() ? nullptr : bus_of(ambient_id_)) {
    bus->set_temperature_c(ambient_id_, plant_.ambient_sensor_c());
  }
  set_sense_locked();
  // A consumer's bias request (es_sense_bias) moves gpio-sim's pull too: the
  // part's level is written again at every step, as the pin would hold it.
  if (es_sense_ != nullptr && sense_level_) es_sense_->set_level(*sense_level_);
  if (now_s >= next_plant_log_s_) {
    log_plant_locked(now_s);
    next_plant_log_s_ += options_.plant_log_s;
    if (next_plant_log_s_ < now_s) next_plant_log_s_ = now_s + options_.plant_log_s;
  }
}

void BoardEmulator::log_plant_locked(double now_s) {
  char value[32], detail[200];
  std::snprintf(value, sizeof value, "%.4f", plant_.controlled_c());
  std::snprintf(detail, sizeof detail,
                "die_c=%.4f;sensor_c=%.4f;ambient_c=%.3f;tec_a=%.4f;enabled=%d;opa548_c=%.1f;shutdown=%d", plant_.die_c(),
                plant_.sensor_c(), plant_.ambient_c(), plant_.tec_current_a(), plant_.tec_enabled() ? 1 : 0,
                plant_.opa548_junction_c(), (plant_.opa548_thermal_shutdown() || injected_shutdown_) ? 1 : 0);
  log_.add(now_s, "plant", "casing_c", value, detail);
}

void BoardEmulator::run_plant() {
  double next_s = clock_.now_s();
  double next_flush_s = next_s + 1.0;
  while (running_.load()) {
    step_plant();
    const double now_s = clock_.now_s();
    if (now_s >= next_flush_s) {
      // The ADS1251's counts, once a second (cumulative).
      const AdcEmulator::Stats a = adc_.stats();
      char detail[160];
      std::snprintf(detail, sizeof detail, "transfers=%llu;clean=%llu;corrupted=%llu;corrupted_used=%llu;late_edges=%llu",
                    static_cast<unsigned long long>(a.chip.reads), static_cast<unsigned long long>(a.chip.clean_reads),
                    static_cast<unsigned long long>(a.chip.corrupted_reads),
                    static_cast<unsigned long long>(a.corrupted_then_used),
                    static_cast<unsigned long long>(a.chip.late_edges));
      log_.add(now_s, "adc", "counts", std::to_string(a.chip.conversions), detail);
      log_.flush();
      next_flush_s = now_s + 1.0;
    }
    next_s = std::max(next_s + options_.thermal_step_s, now_s);
    clock_.sleep_until(next_s);
  }
}

void BoardEmulator::run_es() {
  while (running_.load()) {
    poll_es();
    clock_.sleep_until(clock_.now_s() + options_.es_poll_s);
  }
}

BoardEmulator::Snapshot BoardEmulator::snapshot() {
  const std::lock_guard lock(mutex_);
  return {clock_.now_s(), plant_.controlled_c(), plant_.die_c(), plant_.sensor_c(), plant_.ambient_c(),
          plant_.tec_current_a(), es_enabled_, injected_shutdown_ || plant_.opa548_thermal_shutdown(),
          tec_dac_.code(), rate_dac_.code()};
}

std::string BoardEmulator::status_locked(double now_s, const AdcEmulator::Stats& adc) {
  char text[600];
  std::snprintf(text, sizeof text,
                "ok t_s=%.3f casing_c=%.4f die_c=%.4f sensor_c=%.4f ambient_c=%.3f tec_a=%.4f tec_dac=%u "
                "rate_dac=%u es=%d opa548=%s adc_conversions=%llu adc_transfers=%llu adc_corrupted=%llu "
                "adc_corrupted_used=%llu adc_late_edges=%llu",
                now_s, plant_.controlled_c(), plant_.die_c(), plant_.sensor_c(), plant_.ambient_c(), plant_.tec_current_a(),
                tec_dac_.code(), rate_dac_.code(), es_enabled_ ? 1 : 0,
                (injected_shutdown_ || plant_.opa548_thermal_shutdown()) ? "shutdown"
                : es_enabled_                                           ? "enabled"
                                                                        : "disabled",
                static_cast<unsigned long long>(adc.chip.conversions), static_cast<unsigned long long>(adc.chip.reads),
                static_cast<unsigned long long>(adc.chip.corrupted_reads),
                static_cast<unsigned long long>(adc.corrupted_then_used),
                static_cast<unsigned long long>(adc.chip.late_edges));
  return text;
}

std::string BoardEmulator::apply(const std::string& command) {
  std::istringstream in(command);
  std::vector<std::string> w;
  for (std::string word; in >> word;) w.push_back(word);
  const double now_s = clock_.now_s();
  const auto usage = [](const std::string& why) { return "error: " + why + " (see gyrotc-emu ctl --help)"; };
  if (w.empty()) return usage("empty command");
  const std::string& verb = w[0];

  if (verb == "status" && w.size() == 1) {
    const AdcEmulator::Stats stats = adc_.stats();  // before the board's lock: the ADC's comes first
    const std::lock_guard lock(mutex_);
    return status_locked(now_s, stats);
  }
  if (verb == "mark" && w.size() >= 2) {
    std::string text = command.substr(command.find("mark") + 5);
    std::replace(text.begin(), text.end(), ',', ';');
    log_.add(now_s, "mark", "", text);
    log_.flush();
    return "ok";
  }
  if (verb == "rate" && w.size() == 2) {
    const auto v = number(w[1]);
    if (!v) return usage("rate wants deg/s, got '" + w[1] + "'");
    const std::lock_guard lock(mutex_);
    rate_dps_ = *v;
    log_.add(now_s, "rate", "set", w[1]);
    return "ok";
  }
  if (verb == "ambient" && (w.size() == 2 || w.size() == 3)) {
    const auto c = number(w[1]);
    const auto ramp = w.size() == 3 ? number(w[2]) : std::optional<double>(0.0);
    if (!c || !ramp) return usage("ambient wants a temperature in C and an optional ramp in C/s");
    const std::lock_guard lock(mutex_);
    ambient_c_ = *c;
    ambient_ramp_c_per_s_ = *ramp;
    ambient_set_at_s_ = now_s;
    chamber_.reset();
    log_.add(now_s, "ambient", "set", w[1], w.size() == 3 ? "ramp_c_per_s=" + w[2] : "");
    return "ok";
  }
  if (verb == "chamber" && w.size() == 2) {
    try {
      model::ChamberProfile profile = app::load_chamber_profile(w[1]);
      const std::lock_guard lock(mutex_);
      chamber_ = std::move(profile);
      chamber_start_s_ = now_s;
      log_.add(now_s, "ambient", "chamber", w[1]);
      char reply[160];
      std::snprintf(reply, sizeof reply, "ok chamber profile of %.0f s started", chamber_->end_s());
      return reply;
    } catch (const std::exception& e) {
      return std::string("error: ") + e.what();
    }
  }
  if (verb == "fault" && w.size() == 3) {
    const std::string& what = w[1];
    if (what == "casing" || what == "ambient") {
      const std::string& id = what == "casing" ? casing_id_ : ambient_id_;
      if (id.empty()) return usage("this board has no ambient sensor");
      const auto fault = sensor_fault_named(w[2]);
      if (!fault) {
        return usage("sensor faults: none, disconnect, crc, stuck, power-on-reset, all-zero, low-resolution; got '" +
                     w[2] + "'");
      }
      bus_of(id)->set_fault(id, *fault, now_s);
      log_.add(now_s, "fault", what + "_sensor", w[2], id);
      log_.flush();
      return "ok";
    }
    const auto on = on_off(w[2]);
    if (!on) return usage("fault " + what + " wants on or off, got '" + w[2] + "'");
    if (what == "drdy-stall") {
      adc_.set_drdy_stall(*on);
    } else if (what == "opa548-shutdown") {
      const std::lock_guard lock(mutex_);
      injected_shutdown_ = *on;
      set_sense_locked();
    } else {
      return usage("faults: casing, ambient, drdy-stall, opa548-shutdown, spi-error; got '" + what + "'");
    }
    log_.add(now_s, "fault", what, w[2]);
    log_.flush();
    return "ok";
  }
  if (verb == "fault" && w.size() == 4 && w[1] == "spi-error") {
    const auto on = on_off(w[3]);
    if (!on) return usage("fault spi-error DEVICE wants on or off, got '" + w[3] + "'");
    if (w[2] == "adc") {
      adc_.set_spi_error(*on);
    } else if (w[2] == "rate_dac") {
      rate_dac_.spi_error.store(*on);
    } else if (w[2] == "tec_dac") {
      tec_dac_.spi_error.store(*on);
    } else {
      return usage("spi-error devices: adc, rate_dac, tec_dac; got '" + w[2] + "'");
    }
    log_.add(now_s, "fault", "spi-error-" + w[2], w[3]);
    log_.flush();
    return "ok";
  }
  return usage("unknown command '" + command + "'");
}

}  // namespace gyrotc::emu
