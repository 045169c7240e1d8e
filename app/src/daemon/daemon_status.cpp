#include "gyrotc/app/daemon/daemon_status.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "gyrotc/algorithms/text/printf_string.hpp"
#include "gyrotc/app/runtime/controller.hpp"

namespace gyrotc::app {
namespace {

std::vector<std::string> names_of(std::uint32_t flags) {
  std::vector<std::string> names;
  for (unsigned bit = 0; bit < 32; ++bit) {
    const std::uint32_t flag = 1u << bit;
    if ((flags & flag) == 0) continue;
    const std::string name = flag_name(flag);
    names.push_back(name.empty() ? "bit_" + std::to_string(bit) : name);
  }
  return names;
}

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// A Prometheus label value: backslash, double quote and newline escaped.
std::string label_value(std::string_view v) {
  std::string out;
  for (char c : v) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

}  // namespace

std::string state_word(const DaemonStatus& s) {
  if (!s.running) return "stopped";
  if ((s.flags & kFaultFlags) != 0) return "fault";
  if (!std::isfinite(s.casing_c)) return "starting";
  if (s.mode == "experiment") return "experiment";
  if (s.mode == "tec_off") return "tec_off";
  if ((s.flags & kFlagTecSaturated) != 0) return "saturated";
  if ((s.flags & kFlagModelClamped) != 0) return "extrapolating";
  const double error_c = s.casing_c - s.setpoint_c;
  if (std::fabs(error_c) <= kHoldingBandC) return "holding";
  return error_c < 0.0 ? "warming" : "cooling";
}

std::string status_sentence(const DaemonStatus& s) {
  const std::string state = state_word(s);
  if (state == "stopped") return "stopped (" + s.stopped_by + "): TEC at 0 A, OPA548 disabled";
  if (state == "fault") {
    std::string names;
    for (const std::string& n : names_of(s.flags & kFaultFlags)) names += (names.empty() ? "" : "+") + n;
    return "fault " + names + text::printf_string(": casing %.2f °C, TEC %+.2f A", s.casing_c, s.tec_a);
  }
  if (state == "starting") return "starting: no casing reading yet, TEC off";
  if (state == "experiment")
    return text::printf_string("experiment (%s): casing %.2f °C, TEC %+.2f A",
                               s.experiment.empty() ? "TEC programme" : s.experiment.c_str(), s.casing_c, s.tec_a);
  if (state == "extrapolating") {
    return text::printf_string("extrapolating: compensated at %.2f °C, outside the calibration's %.1f..%.1f °C; "
                               "casing %.2f °C, TEC %+.2f A",
                               s.compensation_c, s.calibration_lo_c, s.calibration_hi_c, s.casing_c, s.tec_a);
  }
  if (state == "tec_off") return text::printf_string("TEC off (compensation only): casing %.2f °C", s.casing_c);
  if (state == "holding") {
    return text::printf_string("holding %.2f °C ±%.2f, TEC %+.2f A", s.setpoint_c, s.held_error_c, s.tec_a);
  }
  if (state == "saturated") {
    return text::printf_string("saturated: casing %.2f °C for %.2f °C, TEC %+.2f A (the limit)", s.casing_c,
                               s.setpoint_c, s.tec_a);
  }
  return text::printf_string("%s to %.2f °C: casing %.2f °C, TEC %+.2f A", state.c_str(), s.setpoint_c, s.casing_c,
                             s.tec_a);
}

std::string status_json(const DaemonStatus& s) {
  nlohmann::json j;
  j["format"] = "gyrotc-status";
  j["version"] = 1;
  j["running"] = s.running;
  j["state"] = state_word(s);
  j["summary"] = status_sentence(s);
  if (!s.running) j["stopped_by"] = s.stopped_by;
  j["pid"] = s.pid;
  j["hal"] = s.hal;
  j["config"] = s.config;
  j["mode"] = s.mode;
  j["started_unix_s"] = s.started_unix_s;
  j["written_unix_s"] = s.written_unix_s;
  j["uptime_s"] = s.uptime_s;
  j["casing_c"] = number_or_null(s.casing_c);
  j["ambient_c"] = number_or_null(s.ambient_c);
  j["setpoint_c"] = number_or_null(s.setpoint_c);
  j["error_c"] = number_or_null(s.casing_c - s.setpoint_c);
  j["held_error_c"] = number_or_null(s.held_error_c);
  j["tec_a"] = s.tec_a;
  j["tec_limit_a"] = s.tec_limit_a;
  j["compensation_c"] = number_or_null(s.compensation_c);
  j["estimate"] = std::isfinite(s.estimate.held_c) ? nlohmann::json{{"held_c", s.estimate.held_c},
                                                                      {"ambient_c", number_or_null(s.estimate.ambient_c)},
                                                                      {"holding_a", number_or_null(s.estimate.holding_a)}}
                                                    : nlohmann::json(nullptr);
  j["flags"] = s.flags;
  j["flag_names"] = names_of(s.flags);
  nlohmann::json faults = nlohmann::json::array();
  for (const FaultEvent& f : s.faults) {
    const bool active = f.cleared_unix_s == 0.0;
    faults.push_back({{"name", f.name},
                      {"active", active},
                      {"raised_unix_s", f.raised_unix_s},
                      {"cleared_unix_s", active ? nlohmann::json(nullptr) : nlohmann::json(f.cleared_unix_s)}});
  }
  j["faults"] = faults;
  j["calibration"] = {{"description", s.calibration},
                      {"sha256", s.calibration_sha256},
                      {"range_c", std::isfinite(s.calibration_lo_c)
                                      ? nlohmann::json::array({s.calibration_lo_c, s.calibration_hi_c})
                                      : nlohmann::json(nullptr)},
                      {"bound_dps", number_or_null(s.calibration_bound_dps)}};
  j["latency_us"] = latency_us_json(s.latency);
  const LoopCounters& c = s.counters;
  j["counters"] = {{"samples", c.samples},
                   {"pid_ticks", c.pid_ticks},
                   {"readings", c.readings},
                   {"overruns", c.overruns},
                   {"missed_conversions", c.missed_conversions},
                   {"late_reads", c.late_reads},
                   {"spurious_edges", c.spurious_edges},
                   {"adc_timeouts", c.adc_timeouts},
                   {"rows_dropped", c.rows_dropped}};
  return j.dump(2) + "\n";
}

nlohmann::json latency_us_json(const LatencyHistogram::Summary& l) {
  return {{"count", l.count},     {"min", l.min_s * 1e6},   {"avg", l.avg_s * 1e6}, {"p50", l.p50_s * 1e6},
          {"p99", l.p99_s * 1e6}, {"p99_over", l.p99_over}, {"max", l.max_s * 1e6}};
}

std::string prometheus_text(const DaemonStatus& s) {
  std::string out;
  const auto metric = [&out](const char* name, const char* type, const char* help) {
    out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
  };
  const auto value = [&out](const std::string& series, double v) {
    // Prometheus spells the special values NaN, +Inf and -Inf.
    out += series + " " +
           (std::isnan(v)   ? std::string("NaN")
            : std::isinf(v) ? (v > 0 ? "+Inf" : "-Inf")
                            : text::printf_string("%.9g", v)) +
           "\n";
  };
  metric("gyrotc_up", "gauge",
         "1 while the daemon runs its loop, 0 once it has stopped (TEC at 0 A, OPA548 disabled).");
  value("gyrotc_up", s.running ? 1.0 : 0.0);
  metric("gyrotc_state", "gauge", "The daemon's state: 1 for the current one (gyrotc status).");
  for (const char* st :
       {"starting", "warming", "cooling", "holding", "saturated", "tec_off", "experiment", "extrapolating", "fault",
        "stopped"}) {
    value(std::string("gyrotc_state{state=\"") + st + "\"}", state_word(s) == st ? 1.0 : 0.0);
  }
  metric("gyrotc_casing_temperature_celsius", "gauge", "Casing temperature (DS18B20), last valid reading.");
  value("gyrotc_casing_temperature_celsius", s.casing_c);
  if (std::isfinite(s.ambient_c)) {
    metric("gyrotc_ambient_temperature_celsius", "gauge", "Ambient temperature (second DS18B20), last reading.");
    value("gyrotc_ambient_temperature_celsius", s.ambient_c);
  }
  metric("gyrotc_setpoint_celsius", "gauge", "Casing setpoint in use (ramped).");
  value("gyrotc_setpoint_celsius", s.setpoint_c);
  metric("gyrotc_holding_error_max_celsius", "gauge",
         "Largest |casing - setpoint| since the casing came within 0.3 C of the setpoint, over 60 s at most "
         "(NaN outside that band).");
  value("gyrotc_holding_error_max_celsius", s.held_error_c);
  metric("gyrotc_tec_current_amperes", "gauge", "TEC current commanded (0 when the TEC is off).");
  value("gyrotc_tec_current_amperes", s.tec_a);
  metric("gyrotc_tec_current_limit_amperes", "gauge", "The PID's TEC current limit.");
  value("gyrotc_tec_current_limit_amperes", s.tec_limit_a);
  metric("gyrotc_compensation_temperature_celsius", "gauge",
         "The temperature the rate is compensated at: the casing reading, or the die's estimate with a calibration "
         "of the die.");
  value("gyrotc_compensation_temperature_celsius", s.compensation_c);
  if (std::isfinite(s.estimate.held_c)) {
    metric("gyrotc_estimated_held_temperature_celsius", "gauge",
           "The model-based loop's estimate of the temperature it holds (its sensor's node).");
    value("gyrotc_estimated_held_temperature_celsius", s.estimate.held_c);
    metric("gyrotc_estimated_ambient_temperature_celsius", "gauge",
           "The model-based loop's estimate of the ambient the housing sees.");
    value("gyrotc_estimated_ambient_temperature_celsius", s.estimate.ambient_c);
    metric("gyrotc_holding_current_amperes", "gauge",
           "The TEC current that holds the setpoint against the estimated heat and ambient (model-based loop).");
    value("gyrotc_holding_current_amperes", s.estimate.holding_a);
  }
  metric("gyrotc_flag", "gauge", "Controller flags (docs/GUIDE.md): 1 while raised.");
  for (unsigned bit = 0; bit < 32; ++bit) {
    const char* name = flag_name(1u << bit);
    if (*name != '\0') value(std::string("gyrotc_flag{flag=\"") + name + "\"}", (s.flags >> bit) & 1u ? 1.0 : 0.0);
  }
  metric("gyrotc_uptime_seconds", "gauge", "Seconds since the loop started.");
  value("gyrotc_uptime_seconds", s.uptime_s);
  metric("gyrotc_calibration_info", "gauge", "The compensation model in use (1; the labels say which).");
  value("gyrotc_calibration_info{sha256=\"" + label_value(s.calibration_sha256) + "\",description=\"" +
            label_value(s.calibration) + "\"}",
        1.0);
  if (std::isfinite(s.calibration_lo_c)) {
    metric("gyrotc_calibration_range_celsius", "gauge",
           "The calibration's range: outside it the rate is compensated at its end (state extrapolating).");
    value("gyrotc_calibration_range_celsius{end=\"low\"}", s.calibration_lo_c);
    value("gyrotc_calibration_range_celsius{end=\"high\"}", s.calibration_hi_c);
  }
  if (std::isfinite(s.calibration_bound_dps)) {
    metric("gyrotc_calibration_error_bound_dps", "gauge",
           "The calibration's own 95 % bound on its error over its range, deg/s (its file's [bound]).");
    value("gyrotc_calibration_error_bound_dps", s.calibration_bound_dps);
  }
  const LoopCounters& c = s.counters;
  const struct {
    const char* name;
    const char* help;
    std::uint64_t count;
  } counters[] = {
      {"gyrotc_adc_samples_total", "ADS1251 samples compensated.", c.samples},
      {"gyrotc_pid_ticks_total", "PID periods run.", c.pid_ticks},
      {"gyrotc_casing_readings_total", "Casing readings handed to the controller.", c.readings},
      {"gyrotc_loop_overruns_total", "Loop passes longer than a sample period.", c.overruns},
      {"gyrotc_adc_missed_conversions_total", "ADS1251 conversions never read.", c.missed_conversions},
      {"gyrotc_adc_late_reads_total", "ADS1251 reads past the DOUT window, dropped.", c.late_reads},
      {"gyrotc_adc_spurious_edges_total", "DRDY edges without a conversion (line noise).", c.spurious_edges},
      {"gyrotc_adc_timeouts_total", "DRDY waits that timed out.", c.adc_timeouts},
      {"gyrotc_output_rows_dropped_total", "Output rows dropped (a slow reader).", c.rows_dropped},
  };
  for (const auto& k : counters) {
    metric(k.name, "counter", k.help);
    value(k.name, static_cast<double>(k.count));
  }
  metric("gyrotc_loop_latency_seconds", "gauge",
         "DRDY edge to the sample's read, since start: p50 and p99 (upper bin edges) and max.");
  value("gyrotc_loop_latency_seconds{stat=\"p50\"}", s.latency.p50_s);
  value("gyrotc_loop_latency_seconds{stat=\"p99\"}", s.latency.p99_s);
  value("gyrotc_loop_latency_seconds{stat=\"max\"}", s.latency.max_s);
  return out;
}

std::string write_file_atomically(const std::string& path, std::string_view text) noexcept {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return tmp + ": " + std::strerror(errno);
  (void)::fchmod(fd, 0644);  // the umask (systemd's UMask=0027) would hide it from other users
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = tmp + ": " + std::strerror(n < 0 ? errno : EIO);
      ::close(fd);
      ::unlink(tmp.c_str());
      return why;
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) {
    const std::string why = tmp + ": " + std::strerror(errno);
    ::unlink(tmp.c_str());
    return why;
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = path + ": " + std::strerror(errno);
    ::unlink(tmp.c_str());
    return why;
  }
  return "";
}

}  // namespace gyrotc::app
