#include "gyrotc/algorithms/model/chamber_profile.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace gyrotc::model {

ChamberProfile::ChamberProfile(std::vector<ProfileSegment> segments)
    : segments_(std::move(segments)) {
  if (segments_.empty()) throw std::invalid_argument("chamber profile has no segments");
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    const auto& s = segments_[i];
    const std::string where = "chamber profile segment '" + s.name + "'";
    if (!std::isfinite(s.start_s) || !std::isfinite(s.end_s) || !std::isfinite(s.ambient_start_c) ||
        !std::isfinite(s.ambient_end_c))
      throw std::invalid_argument(where + " has a value that is not a number");
    if (s.end_s < s.start_s) throw std::invalid_argument(where + " ends before it starts");
    if (i > 0 && std::fabs(s.start_s - segments_[i - 1].end_s) > 1e-9)
      throw std::invalid_argument(where + " does not start where the previous segment ends");
  }
}

ChamberProfile ChamberProfile::table2() {
  constexpr double kSoakS = 3600.0;     // seed Section 4.2: 60 min at each point
  constexpr double kRampCPerS = 1.0 / 60.0;  // 1 C/min (assumption, as for Fig. 26)
  std::vector<ProfileSegment> segments;
  double t = 0.0;
  for (int temp = -40; temp <= 80; temp += 5) {  // seed Table 2: -40..80 C, 5 C steps
    if (temp > -40) {
      const double ramp_s = 5.0 / kRampCPerS;
      segments.push_back({"ramp to " + std::to_string(temp) + " C", t, t + ramp_s, temp - 5.0,
                          static_cast<double>(temp)});
      t += ramp_s;
    }
    segments.push_back({"soak " + std::to_string(temp) + " C", t, t + kSoakS,
                        static_cast<double>(temp), static_cast<double>(temp)});
    t += kSoakS;
  }
  return ChamberProfile(std::move(segments));
}

std::size_t ChamberProfile::segment_at(double t_s) const noexcept {
  const std::size_t n = segments_.size();
  std::size_t i = cursor_ < n ? cursor_ : 0;
  if (t_s < segments_[i].start_s) i = 0;
  while (i + 1 < n && t_s >= segments_[i].end_s) ++i;
  cursor_ = i;
  return i;
}

double ChamberProfile::ambient_c(double t_s) const noexcept {
  if (t_s <= segments_.front().start_s) return segments_.front().ambient_start_c;
  if (t_s >= segments_.back().end_s) return segments_.back().ambient_end_c;
  const auto& s = segments_[segment_at(t_s)];
  const double length = s.end_s - s.start_s;
  if (!(length > 0.0)) return s.ambient_end_c;
  const double f = (t_s - s.start_s) / length;
  return s.ambient_start_c + f * (s.ambient_end_c - s.ambient_start_c);
}

}  // namespace gyrotc::model
