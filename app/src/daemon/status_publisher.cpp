#include "gyrotc/app/daemon/status_publisher.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "gyrotc/app/runtime/controller.hpp"
#include "gyrotc/app/support/log.hpp"

namespace gyrotc::app {
namespace {

constexpr double kErrorWindowS = 60.0;
constexpr int kStateConfirmUpdates = 3;
constexpr std::size_t kFaultHistory = 16;
// Operating states, not faults: not in the fault history.
constexpr std::uint32_t kNotFaults = kFlagTecSaturated | kFlagTecOff;

}  // namespace

StatusPublisher::StatusPublisher(StatusPublisherOptions options)
    : options_(std::move(options)), status_(options_.identity) {}

void set_status_calibration(DaemonStatus& status, const CalibrationInUse& calibration) {
  status.calibration = describe(calibration);
  status.calibration_sha256 = calibration.sha256;
  status.calibration_lo_c = calibration.model.t_min_c();
  status.calibration_hi_c = calibration.model.t_max_c();
  status.calibration_bound_dps = calibration.bound ? calibration.bound->range_dps : kNoValue;
}

void StatusPublisher::set_calibration(const CalibrationInUse& calibration) {
  set_status_calibration(status_, calibration);
}

void StatusPublisher::track_faults(std::uint32_t flags, double now_unix_s) {
  for (unsigned bit = 0; bit < 32; ++bit) {
    const std::uint32_t flag = 1u << bit;
    if ((flag & kNotFaults) != 0 || *flag_name(flag) == '\0') continue;
    const std::string name = flag_name(flag);
    auto active = std::find_if(status_.faults.begin(), status_.faults.end(),
                               [&](const FaultEvent& f) { return f.name == name && f.cleared_unix_s == 0.0; });
    const bool on = (flags & flag) != 0;
    if (on && active == status_.faults.end()) status_.faults.push_back({name, now_unix_s, 0.0});
    if (!on && active != status_.faults.end()) active->cleared_unix_s = now_unix_s;
  }
  while (status_.faults.size() > kFaultHistory) {
    auto cleared = std::find_if(status_.faults.begin(), status_.faults.end(),
                                [](const FaultEvent& f) { return f.cleared_unix_s != 0.0; });
    if (cleared == status_.faults.end()) break;
    status_.faults.erase(cleared);
  }
}

void StatusPublisher::set_files(const std::string& status_file, const std::string& metrics_file) {
  const std::string old_status = std::exchange(options_.status_file, status_file);
  const std::string old_metrics = std::exchange(options_.metrics_file, metrics_file);
  if (old_status == status_file && old_metrics == metrics_file) return;
  status_warned_ = false;
  metrics_warned_ = false;
  // The new files first (after the first update: before it there is nothing
  // to say), then the old ones go: one no longer written would only go
  // stale and read as a daemon that died.
  if (status_.written_unix_s > 0.0) write();
  const auto retire = [](const std::string& old_path, const std::string& path, const char* key) {
    if (old_path == path) return;
    if (!old_path.empty()) std::remove(old_path.c_str());
    GYROTC_LOG_NOTICE("[output] %s: now %s", key, path.empty() ? "none" : path.c_str());
  };
  retire(old_status, status_file, "status_file");
  retire(old_metrics, metrics_file, "metrics_file");
}

void StatusPublisher::set_control(std::string mode, double tec_limit_a) {
  status_.mode = std::move(mode);
  status_.tec_limit_a = tec_limit_a;
}

std::string StatusPublisher::update(const LoopStatus& loop, const LoopCounters& counters,
                                    const LatencyHistogram::Summary& latency, double uptime_s, double now_unix_s) {
  status_.written_unix_s = now_unix_s;
  status_.uptime_s = uptime_s;
  status_.casing_c = loop.casing_c;
  status_.ambient_c = loop.ambient_c;
  status_.setpoint_c = loop.setpoint_c;
  status_.tec_a = loop.tec_a;
  status_.flags = loop.flags;
  status_.compensation_c = loop.compensation_c;
  status_.estimate = loop.estimate;
  status_.counters = counters;
  status_.latency = latency;
  // How well it holds: the stretch since the casing last came into the band, up to 60 s.
  const double error_c = std::fabs(loop.casing_c - loop.setpoint_c);
  if (std::isfinite(error_c) && error_c <= kHoldingBandC) {
    errors_.emplace_back(uptime_s, error_c);
  } else {
    errors_.clear();
  }
  while (!errors_.empty() && errors_.front().first < uptime_s - kErrorWindowS) errors_.pop_front();
  status_.held_error_c = std::nan("");
  for (const auto& e : errors_) {
    status_.held_error_c = std::isnan(status_.held_error_c) ? e.second : std::max(status_.held_error_c, e.second);
  }
  track_faults(loop.flags, now_unix_s);

  const std::string sentence = status_sentence(status_);
  const std::string state = state_word(status_);
  candidate_count_ = state == candidate_state_ ? candidate_count_ + 1 : 1;
  candidate_state_ = state;
  // The first state is told at once; a change once it has lasted.
  if (state != logged_state_ && (logged_state_.empty() || candidate_count_ >= kStateConfirmUpdates)) {
    GYROTC_LOG_NOTICE("state: %s", sentence.c_str());
    logged_state_ = state;
  }
  write();
  return sentence;
}

void StatusPublisher::stopped(const std::string& stopped_by, const LoopCounters& counters,
                              const LatencyHistogram::Summary& latency, double uptime_s, double now_unix_s) {
  status_.running = false;
  status_.stopped_by = stopped_by;
  status_.tec_a = 0.0;
  status_.counters = counters;
  status_.latency = latency;
  status_.uptime_s = uptime_s;
  status_.written_unix_s = now_unix_s;
  write();
}

void StatusPublisher::write() {
  if (!options_.status_file.empty()) {
    write_one(options_.status_file, status_json(status_), "status_file", status_warned_);
  }
  if (!options_.metrics_file.empty()) {
    write_one(options_.metrics_file, prometheus_text(status_), "metrics_file", metrics_warned_);
  }
}

void StatusPublisher::write_one(const std::string& path, const std::string& text, const char* key, bool& warned) {
  const std::string error = write_file_atomically(path, text);
  if (!error.empty() && !warned) {
    GYROTC_LOG_WARNING("[output] %s: cannot write %s (%s); the daemon runs on without it, told once", key, path.c_str(),
                       error.c_str());
  } else if (error.empty() && warned) {
    GYROTC_LOG_NOTICE("[output] %s: %s written again", key, path.c_str());
  }
  warned = !error.empty();
}

}  // namespace gyrotc::app
