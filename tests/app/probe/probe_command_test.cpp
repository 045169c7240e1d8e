#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "test_paths.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kSimConfig = gyrotc::test::config_file("gyrotc-sim.toml");
const std::string kLinuxConfig = gyrotc::test::config_file("gyrotc-linux.toml");

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A copy of a configuration with text replaced, in the temp directory; its
// calibration stays the one beside the original.
std::string variant(const std::string& from, std::vector<std::pair<std::string, std::string>> edits,
                    const std::string& name) {
  std::string s = read_text(from);
  edits.emplace_back("file = \"calibration.toml\"", "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
  for (const auto& [old_text, new_text] : edits) {
    const std::size_t at = s.find(old_text);
    REQUIRE(at != std::string::npos);
    s.replace(at, old_text.size(), new_text);
  }
  const fs::path path = fs::temp_directory_path() / ("gyrotc-probe-" + name + "-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(path) << s;
  return path.string();
}

struct ProbeRun {
  int status = 0;
  std::string out;
};

// Runs `gyrotc probe <args>` in-process, capturing stdout; status as main()
// would return it.
ProbeRun probe(const std::vector<std::string>& args) {
  CLI::App app;
  app.require_subcommand(1);
  gyrotc::app::add_probe_command(app);
  std::vector<std::string> argv_text{"gyrotc", "probe"};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text) argv.push_back(a.data());

  const fs::path capture = fs::temp_directory_path() / ("gyrotc-probe-" + std::to_string(::getpid()) + ".out");
  std::fflush(stdout);
  const int saved = ::dup(1);
  const int fd = ::open(capture.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ::dup2(fd, 1);
  ::close(fd);
  ProbeRun run;
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const gyrotc::app::CommandExit& e) {
    run.status = e.status();
  } catch (const gyrotc::app::InputError&) {
    run.status = 2;
  }
  std::fflush(stdout);
  ::dup2(saved, 1);
  ::close(saved);
  std::ifstream in(capture);
  std::stringstream text;
  text << in.rdbuf();
  run.out = text.str();
  fs::remove(capture);
  return run;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// The sim example with hal = "linux" (and, so that no machine's real w1 bus
// can answer, a w1 root that does not exist).
std::string linux_variant() {
  std::ifstream in(kSimConfig);
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  s.replace(s.find("hal = \"sim\""), 11, "hal = \"linux\"");
  for (std::size_t at; (at = s.find("\"/sys/bus/w1/devices\"")) != std::string::npos;) {
    s.replace(at, 21, "\"/nonexistent-gyrotc-w1\"");
  }
  // The calibration where it is, not beside the copy.
  const std::string calibration = "file = \"calibration.toml\"";
  s.replace(s.find(calibration), calibration.size(),
            "file = \"" + gyrotc::test::config_file("calibration.toml") + "\"");
  const fs::path path = fs::temp_directory_path() / ("gyrotc-probe-linux-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(path) << s;
  return path.string();
}

}  // namespace

TEST_CASE("probe on the sim example reports every device OK and exits 0") {
  const ProbeRun run = probe({"--config", kSimConfig});
  CHECK(run.status == 0);
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);  // header + adc, casing, ambient, rate_dac, tec_dac, opa548, calibration
  CHECK(lines[0] == "board: hal = \"sim\" (" + kSimConfig + ")");
  for (std::size_t i = 1; i < lines.size(); ++i) {
    INFO(lines[i]);
    CHECK(lines[i].substr(16, 2) == "OK");
  }
  CHECK(lines[1].rfind("adc ", 0) == 0);
  CHECK(lines[2].find("16.0000 C") != std::string::npos);  // [sim] initial_temp_c
}

TEST_CASE("probe --json on the sim example lists every device ok") {
  const ProbeRun run = probe({"--config", kSimConfig, "--json"});
  CHECK(run.status == 0);
  const auto json = nlohmann::json::parse(run.out);
  CHECK(json["hal"] == "sim");
  CHECK(json["ok"] == true);
  REQUIRE(json["devices"].size() == 7);
  for (const auto& device : json["devices"]) CHECK(device["status"] == "ok");
}

TEST_CASE("probe --json gives each reading as numbers a script can use, units in the names") {
  const ProbeRun run = probe({"--config", kSimConfig, "--json"});
  const auto json = nlohmann::json::parse(run.out);
  std::map<std::string, nlohmann::json> values;
  for (const auto& device : json["devices"]) {
    if (device.contains("values")) values[device["device"]] = device["values"];
  }
  CHECK(values["casing_sensor"]["temp_c"].is_number());
  CHECK(values["casing_sensor"]["temp_c"].get<double>() == Approx(16.0).margin(0.1));  // the sim's start
  CHECK(values["adc"]["gyro_mv"].is_number());
  CHECK(values["adc"]["missed_conversions"].is_number_unsigned());
  CHECK(values["opa548"]["thermal"] == "clear");
  CHECK(values["calibration"]["range_c"].size() == 2);
  CHECK(values["calibration"]["sha256"].get<std::string>().size() == 64);
}

TEST_CASE("probe with hal = linux and no devices prints one error line per device and exits non-zero") {
  const std::string config = linux_variant();
  const ProbeRun run = probe({"--config", config});
  fs::remove(config);
  CHECK(run.status == 1);
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);
  const std::vector<std::string> devices{"adc", "casing_sensor", "ambient_sensor", "rate_dac", "tec_dac", "opa548"};
  for (std::size_t i = 0; i < devices.size(); ++i) {
    INFO(lines[i + 1]);
    CHECK(lines[i + 1].rfind(devices[i] + " ", 0) == 0);
    CHECK(lines[i + 1].substr(16, 5) == "ERROR");
  }
  CHECK(lines[1].find("'/dev/spidev0.0'") != std::string::npos);
  CHECK(lines[1].find("gpiochip0") != std::string::npos);
  CHECK(lines[4].find("'/dev/spidev6.0'") != std::string::npos);
  CHECK(lines[5].find("'/dev/spidev6.1'") != std::string::npos);
  CHECK(lines[2].find("/nonexistent-gyrotc-w1") != std::string::npos);
  CHECK(lines[7].rfind("calibration     OK", 0) == 0);
}

TEST_CASE("probe on the reference wiring reports the OPA548 thermal state as unknown, a warning, not clear") {
  // deploy/config/gyrotc-linux.toml on the simulated board: no es_sense line.
  const std::string config = variant(kLinuxConfig, {{"\nhal = \"linux\"", "\nhal = \"sim\""}}, "reference");
  const ProbeRun run = probe({"--config", config});
  fs::remove(config);
  CHECK(run.status == 0);  // a warning, not a failure
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);
  INFO(lines[6]);
  CHECK(lines[6].rfind("opa548          WARNING disabled; thermal state unknown: no E/S sense line", 0) == 0);
  CHECK(run.out.find("clear") == std::string::npos);
}

TEST_CASE("probe with an E/S sense line reads the thermal flag with the OPA548 enabled at 0 A") {
  const ProbeRun run = probe({"--config", kSimConfig});
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);
  INFO(lines[6]);
  CHECK(lines[6].find("thermal flag clear (enabled 10 ms at 0 A to read E/S), disabled again") != std::string::npos);
}

TEST_CASE("probe reports the ADC driver's counts of late reads, spurious edges and missed conversions") {
  const ProbeRun run = probe({"--config", kSimConfig});
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);
  INFO(lines[1]);
  CHECK(lines[1].find("200 of 200 reads: late reads 0, spurious edges 0, missed conversions 0") != std::string::npos);
}

TEST_CASE("probe of a board another process holds says so, naming the PID, and writes nothing") {
  // Regular files stand in for the spidev nodes; this process holds the TEC DAC's.
  const std::string dir = fs::temp_directory_path() / ("gyrotc-probe-busy-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* node : {"/adc", "/rate", "/tec"}) std::ofstream(dir + node) << "";
  const int holder = ::open((dir + "/tec").c_str(), O_RDWR | O_CLOEXEC);
  REQUIRE(holder >= 0);
  REQUIRE(::flock(holder, LOCK_EX | LOCK_NB) == 0);
  const std::string config =
      variant(kLinuxConfig,
              {{"spi = \"/dev/spidev0.0\"", "spi = \"" + dir + "/adc\""},
               {"spi = \"/dev/spidev6.0\"", "spi = \"" + dir + "/rate\""},
               {"spi = \"/dev/spidev6.1\"", "spi = \"" + dir + "/tec\""}},
              "busy");
  const ProbeRun run = probe({"--config", config});
  ::close(holder);
  fs::remove(config);
  fs::remove_all(dir);
  CHECK(run.status == 1);
  INFO(run.out);
  CHECK(run.out.find("tec_dac         ERROR   '" + dir + "/tec' is already in use by PID " + std::to_string(::getpid())) !=
        std::string::npos);
  CHECK(run.out.find("SPI_IOC") == std::string::npos);  // no device was configured or written
  CHECK(run.out.find("gpiochip") == std::string::npos);  // no GPIO line was requested
}

TEST_CASE("probe without a readable config file is a usage error") {
  CHECK(probe({"--config", "/nonexistent/gyrotc.toml"}).status == 2);
}

namespace {
// The sim example, copied with its [calibration] file replaced by `file`.
std::string sim_with_calibration(const std::string& name, const std::string& file) {
  std::ifstream in(kSimConfig);
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  const std::string from = "file = \"calibration.toml\"";
  s.replace(s.find(from), from.size(), "file = \"" + file + "\"");
  const std::string path = gyrotc::test::scratch_dir() + "/" + name;
  std::ofstream(path) << s;
  return path;
}
}  // namespace

TEST_CASE("probe names the calibration the configuration names: file, model, range and SHA-256") {
  const ProbeRun run = probe({"--config", kSimConfig, "--json"});
  const auto json = nlohmann::json::parse(run.out);
  const auto& calibration = json["devices"].back();
  CHECK(calibration["device"] == "calibration");
  CHECK(calibration["status"] == "ok");
  const std::string detail = calibration["detail"];
  CHECK(detail.find(gyrotc::test::config_file("calibration.toml") + ": ") == 0);
  // The shipped calibration_table2.toml: fit --method auto chose a spline.
  CHECK(detail.find("spline, -40..80 C") != std::string::npos);
  CHECK(detail.find("sha256 ") != std::string::npos);
}

TEST_CASE("probe reports a missing calibration file as an error naming it, and exits 1") {
  const std::string config = sim_with_calibration("probe_missing_cal.toml", "no-such-calibration.toml");
  const ProbeRun run = probe({"--config", config});
  CHECK(run.status == 1);
  const auto lines = lines_of(run.out);
  REQUIRE(lines.size() == 8);
  CHECK(lines[7].rfind("calibration     ERROR", 0) == 0);
  CHECK(lines[7].find(gyrotc::test::scratch_dir() + "/no-such-calibration.toml: cannot open") != std::string::npos);
}
