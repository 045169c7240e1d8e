#include "test_paths.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace gyrotc::test {

namespace fs = std::filesystem;

namespace {
std::string env(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : "";
}
}  // namespace

std::string root() {
  if (std::string r = env("GYROTC_TEST_ROOT"); !r.empty()) return r;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("..") : exe.parent_path().parent_path().string();
}

std::string data_dir() { return root() + "/share/gyrotc"; }

std::string data_file(const std::string& name) { return data_dir() + "/" + name; }

std::string config_file(const std::string& name) { return root() + "/config/" + name; }

std::string gyrotc_exe() {
  if (std::string e = env("GYROTC_EXE"); !e.empty()) return e;
  const std::string built = root() + "/app/gyrotc";
  if (::access(built.c_str(), X_OK) == 0) return built;
  std::istringstream path(env("PATH"));
  for (std::string dir; std::getline(path, dir, ':');) {
    const std::string candidate = dir + "/gyrotc";
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "gyrotc";
}

std::string scratch_dir() {
  // Removed when the test process exits.
  struct Scratch {
    fs::path dir = fs::temp_directory_path() / ("gyrotc-test-" + std::to_string(::getpid()));
    Scratch() { fs::create_directories(dir); }
    ~Scratch() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  };
  static const Scratch scratch;
  return scratch.dir.string();
}

namespace {

void replace_once(std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  if (at == std::string::npos) throw std::runtime_error("gyrotc-sim.toml has no line " + from);
  text.replace(at, from.size(), to);
}

}  // namespace

std::string sim_config_text(const std::string& name) {
  std::ifstream in(config_file("gyrotc-sim.toml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string config = text.str();
  replace_once(config, "status_file = \"/tmp/gyrotc-sim.status.json\"",
               "status_file = \"" + (fs::path(scratch_dir()) / (name + ".status.json")).string() + "\"");
  return config;
}

std::string sim_config_copy(const std::string& name) {
  std::string config = sim_config_text(name);
  replace_once(config, "file = \"calibration.toml\"", "file = \"" + config_file("calibration.toml") + "\"");
  const fs::path path = fs::path(scratch_dir()) / (name + ".toml");
  std::ofstream(path) << config;
  return path.string();
}

}  // namespace gyrotc::test
