#include "gyrotc/hal/linux/gpio_persistence.hpp"

#include <cstdio>

namespace gyrotc::hal {

std::optional<bool> gpio_outputs_persist(const char* path) noexcept {
  std::FILE* f = std::fopen(path, "re");
  if (f == nullptr) return std::nullopt;
  const int c = std::fgetc(f);  // a bool module parameter reads "Y" or "N"
  std::fclose(f);
  if (c == 'Y' || c == '1') return true;
  if (c == 'N' || c == '0') return false;
  return std::nullopt;
}

}  // namespace gyrotc::hal
