#include "gyrotc/app/support/progress.hpp"

#include <unistd.h>

#include <algorithm>

namespace gyrotc::app {

Progress::Progress(std::string label) : Progress(std::move(label), ::isatty(STDERR_FILENO) == 1) {}

Progress::Progress(std::string label, bool enabled)
    : label_(std::move(label)),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

Progress::~Progress() { finish(); }

void Progress::update(double fraction) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - start_ < std::chrono::seconds(1) || now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  fraction = std::clamp(fraction, 0.0, 1.0);
  constexpr int kWidth = 40;
  const int filled = static_cast<int>(fraction * kWidth);
  const double elapsed_s = std::chrono::duration<double>(now - start_).count();
  const double eta_s = fraction > 0.0 ? elapsed_s * (1.0 - fraction) / fraction : 0.0;
  std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%%  eta %.0f s ", label_.c_str(), filled,
               "########################################", kWidth - filled, "", 100.0 * fraction,
               eta_s);
  std::fflush(stderr);
  drawn_ = true;
}

void Progress::finish() {
  if (!drawn_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace gyrotc::app
