#include "gyrotc/emu/gpio_sim.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {

bool all_digits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
}

// A chip the kernel names: a path, a number, "gpiochipN".
bool kernel_named(const std::string& chip) {
  return chip.find('/') != std::string::npos || all_digits(chip) ||
         (chip.rfind("gpiochip", 0) == 0 && all_digits(chip.substr(8)));
}

std::string read_attribute(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!in || !std::getline(in, text)) throw app::RuntimeFailure("cannot read '" + path + "'");
  return text;
}

void write_attribute(const std::string& path, const std::string& value) {
  std::ofstream out(path);
  out << value;
  out.flush();
  if (!out) throw app::RuntimeFailure("cannot write '" + value + "' to '" + path + "'");
}

void make_dir(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
    throw app::RuntimeFailure("cannot create '" + path + "': " + std::strerror(errno));
  }
}

}  // namespace

GpioSimPlan plan_gpio_sim(const hal::LinuxBoardConfig& devices) {
  struct Want {
    std::string key;
    const hal::GpioRef* ref;
    GpioSimPlace* place;
  };
  GpioSimPlan plan;
  std::vector<Want> wants{{"devices.adc.drdy", &devices.adc_drdy, &plan.drdy},
                          {"devices.opa548.es", &devices.opa548_es, &plan.es}};
  if (devices.opa548_es_sense) {
    plan.es_sense.emplace();
    wants.push_back({"devices.opa548.es_sense", &*devices.opa548_es_sense, &*plan.es_sense});
  }
  for (const Want& w : wants) {
    if (kernel_named(w.ref->chip)) {
      throw app::InputError(w.key + ": chip \"" + w.ref->chip +
                            "\" is named by the kernel, which numbers gpio-sim chips itself: name the chip by a "
                            "label in the configuration the emulator serves, e.g. \"gyrotc-emu:" +
                            (all_digits(w.ref->line) ? std::string("DRDY") : w.ref->line) + "\"");
    }
    auto bank = std::find_if(plan.banks.begin(), plan.banks.end(),
                             [&](const GpioSimBank& b) { return b.label == w.ref->chip; });
    if (bank == plan.banks.end()) {
      plan.banks.push_back({w.ref->chip, 0, {}});
      bank = plan.banks.end() - 1;
    }
    GpioSimLine line{w.key, all_digits(w.ref->line) ? std::string() : w.ref->line, 0};
    for (const GpioSimLine& other : bank->lines) {
      const bool same = line.name.empty() ? (other.name.empty() && std::to_string(other.offset) == w.ref->line)
                                          : other.name == line.name;
      if (same) {
        throw app::InputError(w.key + ": \"" + w.ref->chip + ":" + w.ref->line + "\" is " + other.key +
                              "'s line too: each signal needs a line of its own");
      }
    }
    if (line.name.empty()) line.offset = static_cast<unsigned>(std::stoul(w.ref->line));
    bank->lines.push_back(line);
    w.place->bank = static_cast<std::size_t>(bank - plan.banks.begin());
    w.place->active_low = w.ref->active_low;
  }
  // Named lines take the offsets after the highest one given as a number.
  for (GpioSimBank& bank : plan.banks) {
    unsigned next = 0;
    for (const GpioSimLine& l : bank.lines) {
      if (l.name.empty()) next = std::max(next, l.offset + 1);
    }
    for (GpioSimLine& l : bank.lines) {
      if (!l.name.empty()) l.offset = next++;
    }
    for (const GpioSimLine& l : bank.lines) bank.num_lines = std::max(bank.num_lines, l.offset + 1);
  }
  for (const Want& w : wants) {
    const GpioSimBank& bank = plan.banks[w.place->bank];
    for (const GpioSimLine& l : bank.lines) {
      if (l.key == w.key) w.place->offset = l.offset;
    }
  }
  return plan;
}

GpioSimDevice::GpioSimDevice(const GpioSimPlan& plan, std::string name, std::string configfs_root,
                             std::string sysfs_root)
    : plan_(plan), dir_(configfs_root + "/" + name), sysfs_root_(std::move(sysfs_root)) {
  struct stat st {};
  if (::stat(configfs_root.c_str(), &st) != 0) {
    throw app::RuntimeFailure("no gpio-sim under '" + configfs_root +
                              "': load the module (modprobe gpio-sim) with configfs mounted at /sys/kernel/config");
  }
  try {
    make_dir(dir_);
    for (std::size_t b = 0; b < plan_.banks.size(); ++b) {
      const GpioSimBank& bank = plan_.banks[b];
      const std::string bank_dir = dir_ + "/bank" + std::to_string(b);
      make_dir(bank_dir);
      write_attribute(bank_dir + "/num_lines", std::to_string(bank.num_lines));
      write_attribute(bank_dir + "/label", bank.label);
      for (const GpioSimLine& line : bank.lines) {
        if (line.name.empty()) continue;
        const std::string line_dir = bank_dir + "/line" + std::to_string(line.offset);
        make_dir(line_dir);
        write_attribute(line_dir + "/name", line.name);
      }
    }
    write_attribute(dir_ + "/live", "1");
    live_ = true;
    dev_name_ = read_attribute(dir_ + "/dev_name");
    for (std::size_t b = 0; b < plan_.banks.size(); ++b) {
      chips_.push_back(read_attribute(dir_ + "/bank" + std::to_string(b) + "/chip_name"));
    }
  } catch (...) {
    remove();
    throw;
  }
}

GpioSimDevice::~GpioSimDevice() { remove(); }

std::string GpioSimDevice::line_dir(std::size_t bank, unsigned offset) const {
  return sysfs_root_ + "/" + dev_name_ + "/" + chips_.at(bank) + "/sim_gpio" + std::to_string(offset);
}

void GpioSimDevice::remove() noexcept {
  // configfs: live off, then the folders bottom up (rmdir; the attributes go with them).
  if (live_) {
    std::ofstream(dir_ + "/live") << "0";
    live_ = false;
  }
  for (std::size_t b = 0; b < plan_.banks.size(); ++b) {
    const std::string bank_dir = dir_ + "/bank" + std::to_string(b);
    for (const GpioSimLine& line : plan_.banks[b].lines) {
      if (!line.name.empty()) ::rmdir((bank_dir + "/line" + std::to_string(line.offset)).c_str());
    }
    ::rmdir(bank_dir.c_str());
  }
  ::rmdir(dir_.c_str());
}

}  // namespace gyrotc::emu
