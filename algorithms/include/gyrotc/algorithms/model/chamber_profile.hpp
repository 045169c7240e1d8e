#pragma once

#include <cstddef>
#include <string>
#include <vector>

// The temperature programme of a climatic chamber: ambient temperature as a
// piecewise-linear function of time, made of named segments (holds and ramps).
namespace gyrotc::model {

struct ProfileSegment {
  std::string name;  // e.g. "B" (seed Fig. 26) or "soak 25 C"
  double start_s = 0.0;
  double end_s = 0.0;
  double ambient_start_c = 0.0;
  double ambient_end_c = 0.0;

  bool is_hold() const noexcept { return ambient_start_c == ambient_end_c; }
};

class ChamberProfile {
 public:
  // Segments must be contiguous (each starts where the previous ended), in
  // time order, with end_s >= start_s; zero-length segments (a starting
  // point such as Fig. 26's "A") are kept for reports. Throws
  // std::invalid_argument naming the segment otherwise.
  explicit ChamberProfile(std::vector<ProfileSegment> segments);

  // Seed Section 4.2: -40 -> 80 C in 5 C steps, each held for 60 minutes,
  // with 1 C/min ramps between the holds (the ramp rate is our assumption,
  // as for Fig. 26). Hold segments are named "soak <T> C".
  static ChamberProfile table2();

  // Ambient at t_s (linear inside a segment; held before the start and
  // after the end). Fast for increasing t (a cursor), any order works.
  double ambient_c(double t_s) const noexcept;
  // Index of the segment containing t_s (the last one whose start <= t_s
  // and whose end > t_s; the last segment at or after its end).
  std::size_t segment_at(double t_s) const noexcept;

  double start_s() const noexcept { return segments_.front().start_s; }
  double end_s() const noexcept { return segments_.back().end_s; }
  const std::vector<ProfileSegment>& segments() const noexcept { return segments_; }

 private:
  std::vector<ProfileSegment> segments_;
  mutable std::size_t cursor_ = 0;
};

}  // namespace gyrotc::model
