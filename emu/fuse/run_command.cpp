// `gyrotc-emu run`: the simulated board at the kernel's interfaces.
#include <sched.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>
#include <grp.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <toml++/toml.h>

#include "cuse_spidev.hpp"
#include "gyrotc/app/formats/board_config.hpp"
#include "gyrotc/app/daemon/systemd_notify.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/app/formats/plant_file.hpp"
#include "gyrotc/emu/board_emulator.hpp"
#include "gyrotc/emu/control_socket.hpp"
#include "gyrotc/emu/emu_commands.hpp"
#include "gyrotc/emu/gpio_sim.hpp"
#include "gyrotc/hal/linux/monotonic_clock.hpp"
#include "run_command.hpp"
#include "w1_filesystem.hpp"

namespace gyrotc::emu {

namespace {

struct RunOptions {
  std::string config = "/etc/gyrotc/gyrotc.toml";
  std::string plant;
  std::string log;
  std::string control = kDefaultControlSocket;
  std::string gpio_name = "gyrotc-emu";
  std::string group = "gyrotc";
  std::uint64_t seed = 1;
  int priority = 90;
  int slave_ttl = 10;
};

std::string absolute(const std::string& path) {
  return path.empty() || path == "-" ? path : std::filesystem::absolute(path).string();
}

app::BoardConfig load_board(const std::string& path) {
  toml::table root;
  try {
    root = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw app::InputError(path + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  app::BoardConfig board = app::parse_board_config(root, path);
  if (board.hal != app::HalKind::linux_devices) {
    throw app::InputError(path + ": hal = \"sim\": gyrotc-emu serves the devices of a board configuration "
                          "(hal = \"linux\")");
  }
  const auto& d = board.devices;
  if (d.adc_spi == d.rate_dac_spi || d.adc_spi == d.tec_dac_spi || d.rate_dac_spi == d.tec_dac_spi) {
    throw app::InputError(path + ": the ADC and the two DACs need a spidev each (adc " + d.adc_spi + ", rate_dac " +
                          d.rate_dac_spi + ", tec_dac " + d.tec_dac_spi + ")");
  }
  return board;
}

// The nodes belong to `group` with mode 0660, as 60-gyrotc.rules gives the
// real spidev nodes (udev's rules for spidev do not match a CUSE node).
void give_to_group(const std::string& path, const std::string& group) {
  if (group.empty()) return;
  const ::group* g = ::getgrnam(group.c_str());
  if (g == nullptr) {
    std::fprintf(stderr, "gyrotc-emu: warning: no group '%s': %s stays root's (--group)\n", group.c_str(),
                 path.c_str());
    return;
  }
  if (::chown(path.c_str(), 0, g->gr_gid) != 0 || ::chmod(path.c_str(), 0660) != 0) {
    std::fprintf(stderr, "gyrotc-emu: warning: cannot give %s to group %s\n", path.c_str(), group.c_str());
  }
}

void wait_for_node(const std::string& path) {
  struct stat st {};
  for (int i = 0; i < 500; ++i) {
    if (::stat(path.c_str(), &st) == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  throw app::RuntimeFailure("the CUSE device '" + path + "' did not appear within 5 s");
}

void run(const RunOptions& o) {
  if (::geteuid() != 0) {
    throw app::RuntimeFailure("gyrotc-emu run needs root: it creates CUSE devices, a gpio-sim chip and a FUSE mount");
  }
  const app::BoardConfig board = load_board(o.config);
  EmulatorOptions options;
  options.board = board;
  options.plant = app::load_plant(o.plant);
  options.seed = o.seed;
  options.w1.slave_ttl = o.slave_ttl;
  const GpioSimPlan plan = plan_gpio_sim(board.devices);

  // Signals: SIGINT/SIGTERM end the run (waited for below); SIGUSR1 wakes
  // the FUSE threads. Blocked before any thread starts, so only this one
  // takes them.
  install_session_wakeup();
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  // The hardware is not the daemon's to starve: above its SCHED_FIFO loop.
  if (o.priority > 0) {
    sched_param sp{};
    sp.sched_priority = o.priority;
    if (::sched_setscheduler(0, SCHED_FIFO, &sp) != 0) {
      std::fprintf(stderr, "gyrotc-emu: warning: SCHED_FIFO %d not permitted: the emulated chips' timing follows "
                   "the normal scheduler\n", o.priority);
    }
  }

  hal::MonotonicClock clock;
  EventLog log(o.log);
  GpioSimDevice gpio(plan, o.gpio_name);
  SysfsPullPin drdy(gpio.line_dir(plan.drdy.bank, plan.drdy.offset));
  SysfsValuePin es(gpio.line_dir(plan.es.bank, plan.es.offset));
  std::unique_ptr<SysfsPullPin> sense;
  if (plan.es_sense) sense = std::make_unique<SysfsPullPin>(gpio.line_dir(plan.es_sense->bank, plan.es_sense->offset));
  BoardEmulator emulator(options, clock, drdy, es, sense.get(), log);

  const auto& d = board.devices;
  SpidevEndpoint adc(d.adc_spi, emulator.adc());
  SpidevEndpoint rate(d.rate_dac_spi, emulator.rate_dac());
  SpidevEndpoint tec(d.tec_dac_spi, emulator.tec_dac());
  std::vector<std::unique_ptr<CuseSpidev>> nodes;
  for (SpidevEndpoint* e : {&adc, &rate, &tec}) nodes.push_back(std::make_unique<CuseSpidev>(e->name(), *e, log, clock));
  for (auto& n : nodes) n->start();
  for (auto& n : nodes) {
    wait_for_node(n->path());
    give_to_group(n->path(), o.group);
  }
  std::vector<std::unique_ptr<W1Filesystem>> w1;
  for (auto& [root, bus] : emulator.w1_buses()) w1.push_back(std::make_unique<W1Filesystem>(root, bus, log, clock));
  for (auto& fs : w1) fs->start();

  std::filesystem::create_directories(std::filesystem::path(o.control).parent_path());
  ControlServer control(o.control, [&emulator](const std::string& command) { return emulator.apply(command); });
  emulator.start();

  std::string gpio_text;
  for (std::size_t b = 0; b < plan.banks.size(); ++b) {
    gpio_text += (gpio_text.empty() ? "" : ", ") + gpio.chip_name(b) + " '" + plan.banks[b].label + "'";
  }
  std::string w1_text;
  for (auto& fs : w1) w1_text += (w1_text.empty() ? "" : ", ") + fs->root();
  std::printf("gyrotc-emu: serving %s: spidev %s (ADS1251, %.0f SPS), %s (AD5060 rate), %s (AD5060 TEC); gpio-sim "
              "%s; w1 %s (%s%s%s); control %s; log %s\n",
              o.config.c_str(), d.adc_spi.c_str(), d.adc.fclk_hz / 384.0, d.rate_dac_spi.c_str(),
              d.tec_dac_spi.c_str(), gpio_text.c_str(), w1_text.c_str(), emulated_casing_id(board).c_str(),
              d.ambient_sensor ? ", " : "", emulated_ambient_id(board).c_str(), o.control.c_str(),
              o.log.empty() ? "none" : o.log.c_str());
  std::fflush(stdout);
  app::SystemdNotify notify;
  notify.ready();

  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  notify.stopping();
  std::printf("gyrotc-emu: %s: stopping\n", signal_number == SIGINT ? "SIGINT" : "SIGTERM");
  emulator.stop();
  for (auto& fs : w1) fs->stop();
  for (auto& n : nodes) n->stop();
  log.flush();
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto o = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Serve the simulated board at the kernel's interfaces the configuration names, until SIGINT/SIGTERM:\n"
      "  every [devices] spi path as a CUSE character device answering the spidev ioctls, with the\n"
      "    bit-level ADS1251 or AD5060 behind it;\n"
      "  the DRDY, E/S and E/S sense lines as lines of a gpio-sim chip (the configuration names the chip by\n"
      "    label, e.g. drdy = \"gyrotc-emu:DRDY\");\n"
      "  each DS18B20 as a w1_therm folder in a FUSE tree mounted at its w1_root;\n"
      "  the plant (--plant) advanced in real time.\n"
      "Needs root and the modules cuse, gpio-sim and fuse (docs/EMULATOR.md). Faults and the chamber are\n"
      "set while it runs with `gyrotc-emu ctl`; what the hardware saw goes to --log.");
  cmd->add_option("-c,--config", o->config, "the daemon's configuration (hal = \"linux\")")->capture_default_str();
  cmd->add_option("-p,--plant", o->plant, "plant file (gyrotc-plant TOML: capacities, TEC, gyro; initial_temp_c is the "
                                          "chamber's start)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--log", o->log, "event log (CSV: every DAC frame, E/S change, fault, the plant's true state)");
  cmd->add_option("--control", o->control, "control socket for `gyrotc-emu ctl`")->capture_default_str();
  cmd->add_option("--seed", o->seed, "gyro noise seed")->capture_default_str();
  cmd->add_option("--gpio-sim-name", o->gpio_name, "the gpio-sim device's configfs name")->capture_default_str();
  cmd->add_option("--group", o->group, "group of the spidev nodes (mode 0660); \"\" leaves them root's")
      ->capture_default_str();
  cmd->add_option("--priority", o->priority, "SCHED_FIFO priority of the emulator (0: normal scheduler)")
      ->capture_default_str()
      ->check(CLI::Range(0, 99));
  cmd->add_option("--w1-slave-ttl", o->slave_ttl,
                  "w1 searches (10 s apart) an unplugged sensor's folder survives (the kernel's w1 slave_ttl)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  cmd->callback([o] {
    RunOptions abs = *o;
    // FUSE's setup changes to / : every path is made absolute first.
    abs.config = absolute(o->config);
    abs.plant = absolute(o->plant);
    abs.log = absolute(o->log);
    abs.control = absolute(o->control);
    run(abs);
  });
}

}  // namespace gyrotc::emu
