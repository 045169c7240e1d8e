#pragma once

#include <chrono>
#include <cstdio>
#include <string>

namespace gyrotc::app {

// A one-line progress bar on stderr for long runs. It draws only when stderr
// is a terminal and the run has already lasted a second, at most 10 times a
// second, so short runs, pipes, logs and CI stay quiet.
class Progress {
 public:
  explicit Progress(std::string label);
  Progress(std::string label, bool enabled);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // fraction in [0, 1]
  void update(double fraction);
  // Clears the bar (if one was drawn).
  void finish();

 private:
  std::string label_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace gyrotc::app
