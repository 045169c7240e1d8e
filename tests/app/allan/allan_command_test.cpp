// `gyrotc allan` as a user runs it: the JSON fields of issue 9, the rate
// taken from time_s, and a clear error for each kind of bad record.

#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "gyrotc/app/cli/commands.hpp"
#include "gyrotc/app/support/errors.hpp"
#include "gyrotc_catch.hpp"
#include "run_command.hpp"

namespace fs = std::filesystem;
using gyrotc::app::InputError;

namespace {

std::string run_allan(const std::vector<std::string>& args) {
  return gyrotc::test::run_command(gyrotc::app::add_allan_command, "allan", args);
}

fs::path write_temp(const std::string& name, const std::string& text) {
  const fs::path p = fs::temp_directory_path() / ("gyrotc_allan_" + std::to_string(::getpid()) + "_" + name);
  std::ofstream(p) << text;
  return p;
}

// White rate noise of standard deviation sigma_dps sampled at rate_hz: its
// angle random walk is N = sigma / sqrt(rate) deg/sqrt(s).
fs::path white_noise_record(std::size_t samples, double rate_hz, double sigma_dps) {
  std::mt19937_64 rng(952);
  std::normal_distribution<double> noise(0.0, sigma_dps);
  std::string text = "time_s,rate_dps\n";
  for (std::size_t i = 0; i < samples; ++i) {
    text += std::to_string(static_cast<double>(i) / rate_hz) + "," + std::to_string(noise(rng)) + "\n";
  }
  return write_temp("white.csv", text);
}

// The SVG `allan --plot` draws for a white-noise record of `samples` samples.
std::string plot_of_white_noise(std::size_t samples) {
  const fs::path data = white_noise_record(samples, 100.0, 0.1);
  const fs::path svg = fs::temp_directory_path() / ("gyrotc_allan_" + std::to_string(::getpid()) + ".svg");
  run_allan({"--data", data.string(), "--plot", svg.string()});
  std::ifstream in(svg);
  const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  fs::remove(data);
  fs::remove(svg);
  return text;
}

// The message of the InputError the command throws for args.
std::string error_of(const std::vector<std::string>& args) {
  try {
    run_allan(args);
  } catch (const InputError& e) {
    return e.what();
  }
  FAIL("no InputError");
  return {};
}

}  // namespace

TEST_CASE("allan --json gives every field of the issue, with one interval per tau") {
  const fs::path data = white_noise_record(20000, 100.0, 0.1);
  const auto j = nlohmann::json::parse(run_allan({"--data", data.string(), "--json"}));
  fs::remove(data);
  CHECK(j["samples"] == 20000);
  for (const char* key : {"tau_s", "adev_dps", "adev_ci_low_dps", "adev_ci_high_dps", "adev_edf", "hdev_dps"}) {
    INFO(key);
    REQUIRE(j[key].is_array());
    CHECK(j[key].size() == j["tau_s"].size());
  }
  CHECK(j["tau_s"].size() >= 10);
  for (std::size_t i = 0; i < j["tau_s"].size(); ++i) {
    CHECK(j["adev_ci_low_dps"][i].get<double>() < j["adev_dps"][i].get<double>());
    CHECK(j["adev_dps"][i].get<double>() < j["adev_ci_high_dps"][i].get<double>());
    // The Hadamard deviation where three clusters fit in the record, null beyond.
    const bool three_clusters = 3.0 * j["tau_s"][i].get<double>() * 100.0 <= 20000.0;
    CHECK(j["hdev_dps"][i].is_number() == three_clusters);
  }
  // White noise: the angle random walk with its interval; the other terms
  // are not resolved (null), each with its key.
  CHECK(j["arw_deg_per_rt_h"].is_number());
  CHECK(j["arw_deg_per_rt_h_ci"].size() == 2);
  CHECK(j["arw_deg_per_rt_h_upper"].is_null());
  CHECK(j["arw_deg_per_rt_h_if_present"].is_null());
  int with_value = 0;  // the check below must see numbers, or it proves nothing
  for (const std::string key : {"quantisation_deg", "bias_instability_deg_per_h", "rrw_deg_per_h_per_rt_h", "rate_ramp_deg_per_h2"}) {
    INFO(key);
    CHECK(j.contains(key));
    CHECK(j[key].is_null());
    // What the record says of the term if it is there, below its bound.
    CHECK(j.contains(key + "_if_present"));
    if (j[key + "_if_present"].is_number()) {
      ++with_value;
      CHECK(j[key + "_if_present"].get<double>() <= j[key + "_upper"].get<double>());
    }
  }
  CHECK(with_value >= 2);
}

TEST_CASE("allan takes the sample rate from time_s and recovers the angle random walk of white noise") {
  const fs::path data = white_noise_record(20000, 100.0, 0.1);
  const auto j = nlohmann::json::parse(run_allan({"--data", data.string(), "--json"}));
  fs::remove(data);
  CHECK(j["rate_hz"].get<double>() == Approx(100.0).epsilon(1e-6));
  const double n_deg_per_rt_h = 0.1 / std::sqrt(100.0) * 60.0;  // deg/sqrt(s) -> deg/sqrt(h)
  CHECK(j["arw_deg_per_rt_h"].get<double>() == Approx(n_deg_per_rt_h).epsilon(0.10));
}

TEST_CASE("allan --plot writes a log-log SVG with the slope lines") {
  const std::string text = plot_of_white_noise(20000);
  CHECK(text.find("<svg") != std::string::npos);
  CHECK(text.find("slope -1/2") != std::string::npos);
  CHECK(text.find("Hadamard deviation") != std::string::npos);
}

TEST_CASE("allan --plot of a record too short for a Hadamard point still draws the Allan deviation") {
  const std::string text = plot_of_white_noise(2);
  CHECK(text.find("<svg") != std::string::npos);
  CHECK(text.find("Hadamard deviation") == std::string::npos);
}

TEST_CASE("allan refuses a plot format it cannot write") {
  const fs::path data = white_noise_record(100, 100.0, 0.1);
  const std::string message = error_of({"--data", data.string(), "--plot", "adev.png"});
  fs::remove(data);
  CHECK(message.find("only .svg") != std::string::npos);
}

TEST_CASE("allan of a single sample says it needs at least two") {
  const fs::path data = write_temp("one.csv", "time_s,rate_dps\n0,0.1\n");
  const std::string message = error_of({"--data", data.string(), "--rate-hz", "100"});
  fs::remove(data);
  CHECK(message.find(data.string()) != std::string::npos);
  CHECK(message.find("at least 2") != std::string::npos);
}

TEST_CASE("allan names the line where time_s stops increasing") {
  const fs::path data = write_temp("backwards.csv", "time_s,rate_dps\n0,0.1\n0.01,0.2\n0.005,0.1\n0.03,0.0\n");
  const std::string message = error_of({"--data", data.string()});
  fs::remove(data);
  CHECK(message.find(data.string() + ":4") != std::string::npos);
  CHECK(message.find("time_s") != std::string::npos);
}

TEST_CASE("allan names a missing rate column and the columns there are") {
  const fs::path data = write_temp("nocol.csv", "time_s,gyro_mv\n0,1\n0.01,2\n");
  const std::string message = error_of({"--data", data.string()});
  fs::remove(data);
  CHECK(message.find("missing column 'rate_dps'") != std::string::npos);
  CHECK(message.find("gyro_mv") != std::string::npos);
}

TEST_CASE("allan without time_s and without --rate-hz asks for --rate-hz") {
  const fs::path data = write_temp("norate.csv", "rate_dps\n0.1\n0.2\n0.1\n");
  const std::string message = error_of({"--data", data.string()});
  fs::remove(data);
  CHECK(message.find("--rate-hz") != std::string::npos);
}
