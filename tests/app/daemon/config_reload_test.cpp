// SIGHUP: the configuration read again; what changed, what a running daemon
// applies, and what it names as needing a restart.
#include "gyrotc/app/daemon/config_reload.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include "gyrotc/app/formats/controller_file.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "observer_controller_file.hpp"
#include "test_paths.hpp"

using namespace gyrotc::app;
namespace fs = std::filesystem;

namespace {

using Keys = std::vector<std::string>;

Keys changed(const std::string& before, const std::string& after) {
  return changed_keys(toml::parse(before), toml::parse(after));
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

// The simulated board's configuration and its calibration, copied to a scratch folder.
fs::path sim_config_copy() {
  const fs::path dir = fs::path(gyrotc::test::scratch_dir()) / ("reload_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::copy_file(gyrotc::test::config_file("gyrotc-sim.toml"), dir / "gyrotc-sim.toml",
                fs::copy_options::overwrite_existing);
  fs::copy_file(gyrotc::test::config_file("calibration.toml"), dir / "calibration.toml",
                fs::copy_options::overwrite_existing);
  return dir / "gyrotc-sim.toml";
}

void replace_in(const fs::path& file, const std::string& pattern, const std::string& replacement) {
  const std::string text = read(file.string());
  const std::string edited = std::regex_replace(text, std::regex(pattern), replacement);
  REQUIRE(edited != text);
  std::ofstream(file) << edited;
}

}  // namespace

TEST_CASE("changed keys are named section.key, in nested tables too") {
  CHECK(changed("a = 1\n[control]\nkp = 1.0\n", "a = 1\n[control]\nkp = 2.0\n") == Keys{"control.kp"});
  CHECK(changed("[devices.adc]\nspi = \"/dev/spidev0.0\"\n", "[devices.adc]\nspi = \"/dev/spidev1.0\"\n") ==
        Keys{"devices.adc.spi"});
  CHECK(changed("[control]\nkp = 1.0\n", "[control]\nkp = 1.0\n").empty());
}

TEST_CASE("an added or removed key or table is a change") {
  CHECK(changed("[control]\n", "[control]\nki = 0.3\n") == Keys{"control.ki"});
  CHECK(changed("[control]\nki = 0.3\n", "[control]\n") == Keys{"control.ki"});
  CHECK(changed("", "[devices.ambient_sensor]\nid = \"28-1\"\n") == Keys{"devices.ambient_sensor.id"});
}

TEST_CASE("a value of another type is a change, the same value written otherwise is not") {
  CHECK(changed("[control]\nkp = 1\n", "[control]\nkp = 1.0\n") == Keys{"control.kp"});
  CHECK(changed("[control]\nkp = 1.0\n", "[control]\nkp   =   1.0   # comment\n").empty());
}

TEST_CASE("the controller, the calibration and the outputs reload, wiring, HAL, fail-safes and periods do not") {
  for (const char* key : {"control.setpoint_c", "control.kp", "control.ki", "control.kd", "control.period_s",
                          "control.xi_c", "control.out_min_a", "control.out_max_a", "control.pid",
                          "control.controller_file", "calibration.file", "output.status_interval_s", "output.stream",
                          "output.path", "output.record_csv", "output.record_max_mb", "output.status_file",
                          "output.metrics_file"}) {
    INFO(key);
    CHECK(reloadable_key(key));
  }
  for (const char* key :
       {"hal", "devices.adc.spi", "tec.current_limit_a", "sim.seed", "realtime.priority", "failsafe.over_temp_c",
        "output.period_s", "control.sensor_period_s", "control.rate_out_v_per_dps"}) {
    INFO(key);
    CHECK_FALSE(reloadable_key(key));
  }
}

TEST_CASE("a reload plan carries the new setpoint and names the keys that need a restart") {
  const fs::path config = sim_config_copy();
  const toml::table started = toml::parse_file(config.string());
  replace_in(config, "\nsetpoint_c = 55.0", "\nsetpoint_c = 50.0");
  replace_in(config, "\nseed = 1 ", "\nseed = 7 ");
  SessionOptions options;
  options.config_path = config.string();
  const ReloadPlan plan = plan_reload(options, started);
  CHECK(plan.config.controller.setpoint_c == 50.0);
  CHECK(plan.restart_keys == Keys{"sim.seed"});
}

TEST_CASE("a reload plan keeps the command line's --pid over the file") {
  const fs::path config = sim_config_copy();
  const toml::table started = toml::parse_file(config.string());
  SessionOptions options;
  options.config_path = config.string();
  options.pid = false;
  CHECK_FALSE(plan_reload(options, started).config.controller.pid_enabled);
}

TEST_CASE("a reload of a broken file or calibration is refused naming the file, line and key") {
  const fs::path config = sim_config_copy();
  const toml::table started = toml::parse_file(config.string());
  SessionOptions options;
  options.config_path = config.string();
  replace_in(config, "\nkp = 0.48", "\nkp = -1");
  CHECK_THROWS_WITH(plan_reload(options, started),
                    Catch::Contains("gyrotc-sim.toml:") && Catch::Contains("control.kp"));
  replace_in(config, "\nkp = -1", "\nkp = 0.48");
  std::ofstream(config.parent_path() / "calibration.toml") << "not = [valid\n";
  CHECK_THROWS_AS(plan_reload(options, started), InputError);
}

TEST_CASE("a reload that changes the model-based loop, or the loop's type, is one that brings a new loop") {
  ControllerFile file = gyrotc::test::observer_controller_file();
  const ControllerConfig pid;
  const ControllerConfig observer = apply_controller_file(file, pid, "a.toml");
  const ControllerConfig same = apply_controller_file(file, pid, "a.toml");
  file.observer->spec.ambient_noise_c *= 2.0;  // the filter's gain only: the LQ feedback is the same
  const ControllerConfig other_filter = apply_controller_file(file, pid, "b.toml");
  file.setpoint_c = 50.0;
  const ControllerConfig other = apply_controller_file(file, pid, "b.toml");
  CHECK(same_model_based_loop(pid, pid));
  CHECK(same_model_based_loop(observer, same));
  CHECK_FALSE(same_model_based_loop(observer, other_filter));
  CHECK_FALSE(same_model_based_loop(observer, other));
  CHECK_FALSE(same_model_based_loop(pid, observer));
  CHECK_FALSE(same_model_based_loop(observer, pid));
}
