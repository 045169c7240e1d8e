#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <toml++/toml.h>

#include "gyrotc/hal/board.hpp"
#include "gyrotc/hal/linux/linux_board.hpp"
#include "gyrotc/hal/sim/sim_board.hpp"

// The board part of the daemon's configuration file:
//
//   hal = "linux" | "sim"        which board make_board() builds
//   [devices.adc]                ADS1251: spi, drdy, fclk_hz, vref_v, spi_speed_hz, latency_budget_s,
//                                stamp_latency_max_s
//   [devices.rate_dac]           AD5060 #1: spi, vref_v, spi_speed_hz
//   [devices.tec_dac]            AD5060 #2: spi, spi_speed_hz
//   [devices.opa548]             es, es_sense (optional)
//   [devices.casing_sensor]      DS18B20: w1_root, id, source, stuck_after_s
//   [devices.ambient_sensor]     optional second DS18B20, same keys
//   [tec]                        dac_vref_v, gain_a_per_v, current_limit_a
//   [sim]                        seed, thermal_step_s, initial_temp_c, adc_wake_min_us,
//                                adc_wake_max_us, adc_stall_probability, adc_stall_max_us,
//                                adc_irq_delay_max_us, adc_stamp_delay_max_us, adc_spi_start_max_us,
//                                adc_spi_return_max_us
//
// deploy/config/gyrotc-{sim,linux}.toml document every key. Other top-level
// keys and tables belong to the daemon's loader and are left alone here;
// unknown keys inside these sections are errors.
namespace gyrotc::app {

enum class HalKind { linux_devices, sim };

struct SimConfig {
  std::uint64_t seed = 1;
  double thermal_step_s = 0.1;
  // Every node of the plant (and the chamber) at power-on; unset: the
  // plant's default (PlantParams::initial_temp_c).
  std::optional<double> initial_temp_c;
  // The simulated ADS1251 reader's environment (adc_* keys, in microseconds
  // in the file): wake-up latency, stalls, IRQ delivery, SPI start and return.
  // Defaults: a PREEMPT_RT Raspberry Pi 4's typical figures (cyclictest
  // 20-120 us wake-ups; threaded GPIO IRQs; the spidev message pump).
  hal::SimAds1251::Timing adc_timing{.wake_min_s = 20e-6, .wake_max_s = 120e-6, .stall_probability = 0.0,
                                     .stall_max_s = 120e-6, .irq_delay_max_s = 20e-6, .stamp_delay_max_s = 10e-6,
                                     .spi_start_max_s = 20e-6, .spi_return_max_s = 30e-6, .seed = 0};
};

struct BoardConfig {
  HalKind hal = HalKind::sim;
  // Device paths are used by hal = "linux"; the chip settings (ADC clock and
  // reference, DAC references, sensor options, TEC stage) by both.
  hal::LinuxBoardConfig devices;
  SimConfig sim;
};

// Reads hal, [devices], [tec] and [sim] from a parsed file. Throws
// InputError "<source>:<line>: <key>: <why>" on a bad or unknown key, and
// when two DS18B20s are configured without both ids, or with one id for
// both (the casing sensor could bind to the ambient one); with hal =
// "linux" that message lists the DS18B20 ids on the casing sensor's bus.
BoardConfig parse_board_config(const toml::table& root, const std::string& source);

// A built board: exactly one of the two is set.
struct BoardInstance {
  std::unique_ptr<hal::LinuxBoard> linux_board;
  std::unique_ptr<hal::SimBoard> sim_board;
  hal::Board board();
};

enum class SimTiming { lockstep, realtime };

// The PlantParams a hal = "sim" board is built from: the plant's defaults
// with the TEC stage of [tec].
model::PlantParams sim_plant_params(const BoardConfig& config);
hal::SimBoardOptions sim_board_options(const BoardConfig& config, SimTiming timing);

// Builds the configured board. hal = "linux": opens every device, and if any
// fails throws RuntimeFailure naming each failed device.
BoardInstance make_board(const BoardConfig& config, SimTiming timing = SimTiming::lockstep);

}  // namespace gyrotc::app
