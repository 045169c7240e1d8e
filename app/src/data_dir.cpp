#include "gyrotc/app/data_dir.hpp"

#include <cstdlib>
#include <filesystem>

namespace gyrotc::app {

std::string data_dir() {
  if (const char* env = std::getenv("GYROTC_DATA_DIR"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  if (std::filesystem::is_directory(GYROTC_SOURCE_DATA_DIR, ec)) return GYROTC_SOURCE_DATA_DIR;
  return GYROTC_INSTALLED_DATA_DIR;
}

}  // namespace gyrotc::app
