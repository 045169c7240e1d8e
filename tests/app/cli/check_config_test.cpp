// `gyrotc check-config`: a configuration judged as `run` reads it, with no
// device opened, every mistake one line naming the file, line and key.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "run_command.hpp"
#include "test_paths.hpp"

namespace fs = std::filesystem;

namespace {

std::string check(const std::string& path) {
  return gyrotc::test::run_command(gyrotc::app::add_check_config_command, "check-config", {path});
}

std::string error_of(const std::string& path) {
  try {
    check(path);
  } catch (const gyrotc::app::RuntimeFailure& e) {
    return e.what();
  }
  return "no error";
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The board's shipped configuration with every device path made one that
// does not exist, its calibration named by absolute path, and `pattern`
// replaced by `replacement`, written as `name`.
fs::path board_config_without_devices(const std::string& name = "check_config.toml", const std::string& pattern = "",
                                      const std::string& replacement = "") {
  std::string text = read(gyrotc::test::config_file("gyrotc-linux.toml"));
  text = std::regex_replace(text, std::regex("\"/(dev|sys)/"), "\"/nonexistent/$1/");
  text = std::regex_replace(text, std::regex("\"gpiochip0:"), "\"/nonexistent/gpiochip0:");
  text = std::regex_replace(text, std::regex("\nfile = \"calibration.toml\""),
                            "\nfile = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
  if (!pattern.empty()) text = std::regex_replace(text, std::regex(pattern), replacement);
  const fs::path p = fs::temp_directory_path() / (std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST_CASE("check-config passes the shipped board configuration without opening a device") {
  const fs::path p = board_config_without_devices();
  REQUIRE(read(p.string()).find("/nonexistent/dev/spidev0.0") != std::string::npos);
  const std::string out = check(p.string());
  CHECK(out.find(p.string() + ": OK") == 0);
  CHECK(out.find("hal:         linux") != std::string::npos);
  CHECK(out.find("calibration: " + gyrotc::test::config_file("calibration.toml")) != std::string::npos);
  fs::remove(p);
}

TEST_CASE("check-config refuses an unknown key naming the file, line and key") {
  const fs::path p = board_config_without_devices("key.toml", "\n\\[control\\]\n", "\n[control]\nsetpiont_c = 55.0\n");
  const std::string e = error_of(p.string());
  INFO(e);
  const std::string text = read(p.string());
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(text.find("setpiont_c")), '\n');
  CHECK(e.find(p.string() + ":" + std::to_string(line) + ":") == 0);
  CHECK(e.find("setpiont_c") != std::string::npos);
  fs::remove(p);
}

TEST_CASE("check-config refuses a calibration file that is not there, naming it") {
  const fs::path p =
      board_config_without_devices("cal.toml", "\nfile = \"[^\"]*\"", "\nfile = \"/nonexistent/calibration.toml\"");
  CHECK(error_of(p.string()).find("/nonexistent/calibration.toml") != std::string::npos);
  fs::remove(p);
}

TEST_CASE("check-config refuses a control period that cannot run, naming the key") {
  const fs::path p = board_config_without_devices("ctl.toml", "\nperiod_s = 2.0", "\nperiod_s = -2.0");
  const std::string e = error_of(p.string());
  INFO(e);
  CHECK(e.find(p.string()) == 0);
  CHECK(e.find("period_s") != std::string::npos);
  fs::remove(p);
}
