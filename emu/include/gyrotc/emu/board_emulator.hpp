#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "gyrotc/algorithms/model/chamber_profile.hpp"
#include "gyrotc/algorithms/model/plant.hpp"
#include "gyrotc/app/formats/board_config.hpp"
#include "gyrotc/emu/adc_emulator.hpp"
#include "gyrotc/emu/event_log.hpp"
#include "gyrotc/emu/pin_io.hpp"
#include "gyrotc/emu/spidev_endpoint.hpp"
#include "gyrotc/emu/w1_bus.hpp"
#include "gyrotc/hal/sim/sim_ad5060.hpp"

// The simulated board behind the kernel's interfaces (gyrotc-emu): the plant
// model advanced on the real clock, the ADS1251 (adc_emulator.hpp), the two
// AD5060s, the OPA548's E/S pin and the DS18B20s, wired as the daemon's
// board configuration describes the real one:
//
//   rate ADC   <- plant.gyro_mv()            SPI frames and the DRDY/DOUT pin
//   rate DAC   -> latched code, logged       SPI frames
//   TEC DAC    -> plant.set_tec_drive_v()    SPI frames
//   E/S drive  -> plant.set_tec_enabled()    the line the daemon drives (polled)
//   E/S sense  <- enabled and not in thermal shutdown (the part pulls E/S low)
//   DS18B20s   <- plant casing / ambient     w1_therm attributes (w1_bus.hpp)
//
// Every DAC frame, E/S change, fault and (every plant_log_s) the plant's true
// state go to the event log. Faults and the chamber are set while it runs
// (apply(), the control socket's commands: control.hpp).
namespace gyrotc::emu {

struct EmulatorOptions {
  app::BoardConfig board;      // the daemon's configuration: wiring, chip settings
  model::PlantParams plant;    // a plant file (app/plant_file.hpp); its initial_temp_c is the chamber's start
  std::uint64_t seed = 1;
  double thermal_step_s = 0.1;  // plant steps (at most plant.max_thermal_step_s each)
  double plant_log_s = 0.5;
  double es_poll_s = 0.005;    // how often the E/S drive line is read
  W1BusOptions w1;
};

// The sensor ids the emulator serves: the configured ones, or for an empty
// id (one sensor on its bus) a made-up DS18B20 id.
std::string emulated_casing_id(const app::BoardConfig& board);
std::string emulated_ambient_id(const app::BoardConfig& board);

class BoardEmulator final : hal::SimAds1251::Input {
 public:
  // drdy: the line the ADS1251's pin drives; es_drive: the line the daemon
  // drives E/S on; es_sense: the line the daemon reads E/S back on (when the
  // configuration has one).
  BoardEmulator(const EmulatorOptions& options, hal::Clock& clock, PinOutput& drdy, PinInput& es_drive,
                PinOutput* es_sense, EventLog& log);
  ~BoardEmulator() override;
  BoardEmulator(const BoardEmulator&) = delete;
  BoardEmulator& operator=(const BoardEmulator&) = delete;

  // The ADC pin, plant and E/S threads.
  void start();
  void stop();
  // One step of the plant / E/S threads (tests on a virtual clock).
  void step_plant();
  void poll_es();

  SpiTarget& adc() noexcept { return adc_; }
  SpiTarget& rate_dac() noexcept { return rate_dac_; }
  SpiTarget& tec_dac() noexcept { return tec_dac_; }
  AdcEmulator& adc_emulator() noexcept { return adc_; }
  // The w1 buses by root folder (one per w1_root the configuration names).
  std::map<std::string, std::shared_ptr<W1Bus>>& w1_buses() noexcept { return buses_; }

  // A control command ("fault casing disconnect", "status", ...: control.hpp);
  // returns the reply ("ok ..." or "error: ...").
  std::string apply(const std::string& command);

  struct Snapshot {
    // casing_c: what the loop holds, as simulate's record gives it (the plant's
    // controlled_c: for a network plant, the casing sensor's node plus its offset).
    double t_s, casing_c, die_c, sensor_c, ambient_c, tec_a;
    bool es_enabled, opa548_shutdown;
    std::uint16_t tec_code, rate_code;
  };
  Snapshot snapshot();
  const EmulatorOptions& options() const noexcept { return options_; }

 private:
  // An AD5060 on the wire: the bit-level simulator, the event log, and what
  // a latched frame does on the board.
  class Dac final : public SpiTarget, hal::SimAd5060::Listener {
   public:
    Dac(BoardEmulator& board, std::string name, double vref_v, bool tec);
    int transfer(const SpiWire& wire, std::span<const std::uint8_t> tx, std::span<std::uint8_t> rx) override;
    std::uint16_t code() const { return chip_.code(); }
    std::atomic<bool> spi_error{false};

   private:
    void on_dac_output(double output_v, hal::Ad5060PowerDown mode) noexcept override;
    BoardEmulator& board_;
    std::string name_;
    bool tec_;
    hal::SimAd5060 chip_;
    bool latched_ = false;
  };

  double input_mv(double t_s) noexcept override;
  void set_sense_locked();
  void log_plant_locked(double now_s);
  void run_plant();
  void run_es();
  W1Bus* bus_of(const std::string& id);
  std::string status_locked(double now_s, const AdcEmulator::Stats& adc);

  EmulatorOptions options_;
  hal::Clock& clock_;
  PinInput& es_drive_;
  PinOutput* es_sense_;
  EventLog& log_;
  double start_s_;
  std::string casing_id_, ambient_id_;

  // The plant and the board's state below. Lock order: the ADC's mutex
  // (AdcEmulator) before this one (a conversion reads the plant).
  std::mutex mutex_;
  model::Plant plant_;
  double ambient_c_;
  double ambient_ramp_c_per_s_ = 0.0;
  double ambient_set_at_s_ = 0.0;
  std::optional<model::ChamberProfile> chamber_;
  double chamber_start_s_ = 0.0;
  double rate_dps_ = 0.0;
  bool es_enabled_ = false;        // the OPA548's E/S as the daemon drives it
  bool injected_shutdown_ = false;
  std::optional<bool> sense_level_;
  double next_plant_log_s_ = 0.0;

  std::map<std::string, std::shared_ptr<W1Bus>> buses_;
  AdcEmulator adc_;
  Dac rate_dac_;
  Dac tec_dac_;
  std::atomic<bool> running_{false};
  std::thread plant_thread_, es_thread_;
};

}  // namespace gyrotc::emu
