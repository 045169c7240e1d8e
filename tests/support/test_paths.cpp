#include "test_paths.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>

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

}  // namespace gyrotc::test
