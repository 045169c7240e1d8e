#include "gyrotc/emu/hil_report.hpp"

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "gyrotc/app/formats/csv_table.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {

constexpr unsigned kFlagAdcInvalid = 1u << 5;  // app::kFlagAdcInvalid

// A DAC frame in normal mode (not a power-down).
bool normal_frame(const LogEvent& e) { return e.detail.rfind("mode=normal", 0) == 0; }

std::vector<std::string> split(const std::string& line, char sep, std::size_t max_fields) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (out.size() + 1 < max_fields) {
    const std::size_t at = line.find(sep, start);
    if (at == std::string::npos) break;
    out.push_back(line.substr(start, at - start));
    start = at + 1;
  }
  out.push_back(line.substr(start));
  return out;
}

double parse_double(const std::string& text) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    return used == text.size() ? v : std::numeric_limits<double>::quiet_NaN();
  } catch (...) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

std::vector<LogEvent> read_event_log(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw app::InputError(path + ": cannot open the event log");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A line still being written has no newline yet: leave it out.
  if (const std::size_t last = text.rfind('\n'); last != std::string::npos) text.resize(last + 1);
  else text.clear();
  std::istringstream lines(text);
  std::vector<LogEvent> events;
  std::string line;
  std::size_t number = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (number == 1) {
      if (line != "t_s,kind,device,value,detail") throw app::InputError(path + ":1: not a gyrotc-emu event log");
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> f = split(line, ',', 5);
    const double t = f.empty() ? std::nan("") : parse_double(f[0]);
    if (f.size() != 5 || !std::isfinite(t)) {
      throw app::InputError(path + ":" + std::to_string(number) + ": expected t_s,kind,device,value,detail");
    }
    events.push_back({t, f[1], f[2], f[3], f[4]});
  }
  return events;
}

std::optional<double> mark_time(const std::vector<LogEvent>& events, const std::string& text) {
  std::optional<double> t;
  for (const LogEvent& e : events) {
    if (e.kind == "mark" && e.value == text) t = e.t_s;
  }
  return t;
}

SettleResult find_settle(const std::vector<LogEvent>& events, double setpoint_c, double band_c, double hold_s,
                         double after_s) {
  SettleResult r;
  bool in_band = false;
  double stretch_start = 0.0;
  double stretch_max = 0.0;
  for (const LogEvent& e : events) {
    if (e.kind != "plant" || e.device != "casing_c" || e.t_s < after_s) continue;
    const double error_c = parse_double(e.value) - setpoint_c;
    ++r.samples;
    r.last_error_c = error_c;
    if (!(std::fabs(error_c) <= band_c)) {
      in_band = false;
      continue;
    }
    if (!in_band) {
      in_band = true;
      stretch_start = e.t_s;
      stretch_max = 0.0;
    }
    stretch_max = std::max(stretch_max, std::fabs(error_c));
    const double held_s = e.t_s - stretch_start;
    if (held_s > r.longest_hold_s) {
      r.longest_hold_s = held_s;
      r.max_abs_error_c = stretch_max;
    }
    if (held_s >= hold_s) {
      r.settled = true;
      r.settled_at_s = stretch_start;
      r.max_abs_error_c = stretch_max;
      return r;
    }
  }
  return r;
}

std::vector<RecordRow> read_record(const std::string& path) {
  const app::CsvTable table = app::CsvTable::read(path);
  const std::vector<double> time = table.numbers("time_s");
  const std::vector<std::string> rate = table.text("rate_dps_compensated");
  const std::vector<double> flags = table.numbers("flags");
  std::vector<RecordRow> rows(time.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    rows[i] = {time[i], parse_double(rate[i]), static_cast<unsigned>(flags[i])};
  }
  return rows;
}

CompensationResult compare_compensation(const std::vector<LogEvent>& events, const std::vector<RecordRow>& rows,
                                        const DacScale& scale, double after_s, double until_s, double mean_from_s) {
  std::vector<double> t, rate;
  for (const LogEvent& e : events) {
    if (e.kind != "dac" || e.device != "rate_dac" || !normal_frame(e) || e.t_s < after_s || e.t_s > until_s) {
      continue;
    }
    t.push_back(e.t_s);
    rate.push_back(scale.rate_of(static_cast<unsigned>(parse_double(e.value))));
  }
  if (t.size() < 2 || rows.size() < 3) {
    throw app::InputError("compensation: " + std::to_string(t.size()) + " rate-DAC frames and " +
                          std::to_string(rows.size()) + " record rows: too few to compare");
  }
  std::vector<double> prefix(rate.size() + 1, 0.0);
  for (std::size_t i = 0; i < rate.size(); ++i) prefix[i + 1] = prefix[i] + rate[i];
  // The mean of the codes in (a, b], and their count.
  const auto mean_in = [&](double a, double b, std::size_t& n) {
    const auto lo = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), a) - t.begin());
    const auto hi = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), b) - t.begin());
    n = hi > lo ? hi - lo : 0;
    return n > 0 ? (prefix[hi] - prefix[lo]) / static_cast<double>(n) : std::nan("");
  };
  const auto usable = [&](std::size_t k) {
    return k > 0 && std::isfinite(rows[k].rate_dps) && (rows[k].flags & kFlagAdcInvalid) == 0 &&
           (rows[k - 1].flags & kFlagAdcInvalid) == 0;
  };
  // The record's start: near the first frame, within the record's first row.
  CompensationResult best;
  double best_score = std::numeric_limits<double>::infinity();
  const double first_s = t.front() - rows.front().time_s - 1.0;
  for (double start = first_s; start <= t.front() + 1.0; start += 0.0005) {
    double score = 0.0;
    std::size_t compared = 0;
    for (std::size_t k = 1; k < rows.size(); ++k) {
      const double a = start + rows[k - 1].time_s, b = start + rows[k].time_s;
      if (!usable(k) || a < after_s || b > until_s) continue;
      std::size_t n = 0;
      const double m = mean_in(a, b, n);
      if (n == 0) continue;
      score += std::fabs(m - rows[k].rate_dps);
      ++compared;
    }
    if (compared >= 2 && score / static_cast<double>(compared) < best_score) {
      best_score = score / static_cast<double>(compared);
      best.start_s = start;
      best.rows = compared;
    }
  }
  if (best.rows == 0) throw app::InputError("compensation: no record row lies inside the frames' time span");
  best.lsb_dps = scale.lsb_dps();
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const double a = best.start_s + rows[k - 1].time_s, b = best.start_s + rows[k].time_s;
    if (!usable(k) || a < after_s || b > until_s) continue;
    std::size_t n = 0;
    const double m = mean_in(a, b, n);
    if (n == 0) continue;
    best.frames += n;
    const double diff_lsb = std::fabs(m - rows[k].rate_dps) / best.lsb_dps;
    if (diff_lsb > best.max_diff_lsb) {
      best.max_diff_lsb = diff_lsb;
      best.worst_row_time_s = rows[k].time_s;
    }
  }
  double sum = 0.0;
  for (std::size_t i = 0; i < rate.size(); ++i) {
    if (t[i] < mean_from_s) continue;
    sum += rate[i];
    ++best.mean_frames;
  }
  if (best.mean_frames == 0) throw app::InputError("compensation: no rate-DAC frame in the mean's window");
  best.mean_rate_dps = sum / static_cast<double>(best.mean_frames);
  return best;
}

SafeResult find_safe(const std::vector<LogEvent>& events, unsigned zero_code, double after_s) {
  // The state at after_s, then its changes.
  std::optional<unsigned> code;
  std::optional<bool> es;
  int writer = 0;
  SafeResult r;
  const auto check = [&](double t_s) {
    if (t_s < after_s) return;
    const double at = std::max(t_s, after_s);
    if (!r.tec_zero_s && code == zero_code) {
      r.tec_zero_s = at;
      r.tec_zero_pid = t_s >= after_s ? writer : 0;
    }
    if (!r.es_low_s && es == false) r.es_low_s = at;
    if (!r.safe_s && code == zero_code && es == false) r.safe_s = at;
    const bool driving = es == true && code && *code != zero_code;
    if (r.safe_s && !r.resumed_s && driving) r.resumed_s = t_s;
    if (r.es_low_s && !r.es_resumed_s && driving) r.es_resumed_s = t_s;
  };
  bool checked_start = false;
  for (const LogEvent& e : events) {
    if (!checked_start && e.t_s >= after_s) {
      checked_start = true;
      check(after_s);
    }
    if (e.kind == "dac" && e.device == "tec_dac" && normal_frame(e)) {
      code = static_cast<unsigned>(parse_double(e.value));
      const std::size_t at = e.detail.find("pid=");
      writer = at == std::string::npos ? 0 : std::atoi(e.detail.c_str() + at + 4);
    } else if (e.kind == "es" && e.device == "drive") {
      es = e.value == "1";
    } else {
      continue;
    }
    check(e.t_s);
  }
  return r;
}

}  // namespace gyrotc::emu
