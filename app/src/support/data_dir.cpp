#include "gyrotc/app/support/data_dir.hpp"

#include <cstdlib>
#include <filesystem>

namespace gyrotc::app {

std::string executable_dir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

std::string data_dir() {
  if (const char* env = std::getenv("GYROTC_DATA_DIR"); env != nullptr && *env != '\0') return env;
  // GYROTC_DATA_DIR_FROM_BINDIR: the install tree's path from bindir to
  // ${datadir}/gyrotc, "../share/gyrotc" for the usual layout.
  return (std::filesystem::path(executable_dir()) / GYROTC_DATA_DIR_FROM_BINDIR).lexically_normal().string();
}

}  // namespace gyrotc::app
