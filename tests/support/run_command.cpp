#include "run_command.hpp"

#include <CLI/CLI.hpp>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace gyrotc::test {

std::string run_command(void (*add_command)(CLI::App&), const std::string& name,
                        const std::vector<std::string>& args) {
  CLI::App app{"test"};
  add_command(app);
  std::vector<const char*> argv{"gyrotc", name.c_str()};
  for (const auto& a : args) argv.push_back(a.c_str());

  const std::filesystem::path capture =
      std::filesystem::temp_directory_path() / ("gyrotc_" + name + "_stdout_" + std::to_string(::getpid()));
  std::FILE* f = std::fopen(capture.c_str(), "w+");
  if (f == nullptr) throw std::runtime_error("cannot create " + capture.string());
  std::fflush(stdout);
  const int saved = ::dup(::fileno(stdout));
  ::dup2(::fileno(f), ::fileno(stdout));
  const auto restore = [&] {
    std::fflush(stdout);
    ::dup2(saved, ::fileno(stdout));
    ::close(saved);
    std::fclose(f);
  };
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (...) {
    restore();
    std::filesystem::remove(capture);
    throw;
  }
  restore();
  std::ifstream in(capture);
  std::string out((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove(capture);
  return out;
}

}  // namespace gyrotc::test
