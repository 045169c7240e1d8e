#include "gyrotc/app/daemon/row_outputs.hpp"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <utility>

#include "gyrotc/app/runtime/record_columns.hpp"
#include "gyrotc/app/support/log.hpp"
#include "gyrotc/app/support/output_path.hpp"

namespace gyrotc::app {
namespace {

void format_row(const OutputRow& row, char* out, std::size_t size) {
  format_record_row(out, size, row.time_s, row.casing_c, row.ambient_c, row.gyro_mv, row.rate_dps, row.tec_a,
                    row.setpoint_c, row.flags);
}

StreamKind stream_kind(const RowOutputsConfig& c) { return c.stream ? c.output.stream : StreamKind::none; }

// The stream's own settings: a change in any of them opens it anew.
bool same_stream(const RowOutputsConfig& a, const RowOutputsConfig& b) {
  const StreamKind k = stream_kind(a);
  if (k != stream_kind(b)) return false;
  if (k == StreamKind::none) return true;
  if (a.output.write_timeout_s != b.output.write_timeout_s) return false;
  if (k == StreamKind::stdout_stream) return true;
  return a.output.path == b.output.path && (k != StreamKind::serial || a.output.baud == b.output.baud);
}

// The path only: opening the record truncates it, so the same path is never
// opened again (a changed write_timeout_s applies from the next file on).
bool same_record(const RowOutputsConfig& a, const RowOutputsConfig& b) {
  return a.output.record_csv == b.output.record_csv;
}

std::unique_ptr<LineSink> open_stream(const RowOutputsConfig& c) {
  const OutputConfig& o = c.output;
  switch (stream_kind(c)) {
    case StreamKind::stdout_stream: return LineSink::open_stdout(o.write_timeout_s);
    case StreamKind::file:
      prepare_output_file(o.path, "output.path");
      return LineSink::open_file(o.path, true, o.write_timeout_s);
    case StreamKind::serial: return LineSink::open_serial(o.path, o.baud, o.write_timeout_s);
    case StreamKind::none: break;
  }
  return nullptr;
}

// The record is written with at least a second's patience: it is a file on
// the board's own storage, and a calibration run must not lose rows to a slow card.
double record_timeout_s(const RowOutputsConfig& c) { return std::max(c.output.write_timeout_s, 1.0); }

std::unique_ptr<LineSink> open_record(const RowOutputsConfig& c) {
  if (c.output.record_csv.empty()) return nullptr;
  prepare_output_file(c.output.record_csv, c.record_key);
  return LineSink::open_file(c.output.record_csv, false, record_timeout_s(c));
}

std::uint64_t rotate_bytes(const RowOutputsConfig& c) {
  return c.rotate ? static_cast<std::uint64_t>(c.output.record_max_mb * 1e6) : 0;
}

std::string describe_stream(const RowOutputsConfig& c) {
  switch (stream_kind(c)) {
    case StreamKind::stdout_stream: return "stdout";
    case StreamKind::file: return "file " + c.output.path;
    case StreamKind::serial: return "serial " + c.output.path + " at " + std::to_string(c.output.baud) + " baud";
    case StreamKind::none: break;
  }
  return "none";
}

}  // namespace

RowOutputs::RowOutputs(const RowOutputsConfig& config) : config_(config) {
  stream_.lines = open_stream(config_);
  record_.lines = open_record(config_);
}

void RowOutputs::write(const OutputRow& row) {
  char line[256];
  format_row(row, line, sizeof line);
  const std::lock_guard<std::mutex> lock(mutex_);
  if (stream_.lines) {
    if (!std::exchange(stream_.header_written, true)) stream_.lines->write_line(kRecordCsvHeader);
    stream_.lines->write_line(line);
    stream_.lines->flush();
  }
  // A calibration needs a casing temperature and a gyro mean on every row.
  if (!record_.lines || !row.have_casing || row.samples == 0) return;
  const std::uint64_t limit = rotate_bytes(config_);
  if (limit > 0 && record_bytes_ + std::strlen(line) + 1 > limit) rotate_record();
  if (!std::exchange(record_.header_written, true)) {
    record_.lines->write_line(kRecordCsvHeader);
    record_bytes_ += std::strlen(kRecordCsvHeader) + 1;
  }
  record_.lines->write_line(line);
  record_bytes_ += std::strlen(line) + 1;
  record_.lines->flush();
}

void RowOutputs::rotate_record() {
  const std::string& path = config_.output.record_csv;
  try {
    record_.lines->flush();
    std::filesystem::rename(path, path + ".1");
    auto fresh = LineSink::open_file(path, false, record_timeout_s(config_));
    retire(record_);
    record_.lines = std::move(fresh);
    GYROTC_LOG_NOTICE("%s: %s reached record_max_mb, moved to %s.1", config_.record_key.c_str(), path.c_str(),
                      path.c_str());
  } catch (const std::exception& e) {
    GYROTC_LOG_ERROR("%s: rotation failed, recording goes on where it was: %s", config_.record_key.c_str(), e.what());
  }
  record_bytes_ = 0;
}

void RowOutputs::retire(Sink& sink) {
  if (!sink.lines) return;
  sink.lines->flush();
  retired_dropped_ += sink.lines->lines_dropped();
  if (!sink.lines->first_error().empty()) retired_errors_.push_back(sink.lines->first_error());
  sink.lines.reset();
  sink.header_written = false;
}

std::string RowOutputs::reconfigure(const RowOutputsConfig& config) {
  const bool new_stream = !same_stream(config_, config);
  const bool new_record = !same_record(config_, config);
  // Everything that can fail first: a refused path leaves the outputs as they were.
  std::unique_ptr<LineSink> stream = new_stream ? open_stream(config) : nullptr;
  std::unique_ptr<LineSink> record = new_record ? open_record(config) : nullptr;

  std::string changed;
  const auto add = [&changed](const std::string& what) { changed += (changed.empty() ? "" : ", ") + what; };
  if (new_stream) add("stream " + describe_stream(config));
  if (new_record) add("record " + (config.output.record_csv.empty() ? std::string("none") : config.output.record_csv));
  if (rotate_bytes(config) != rotate_bytes(config_)) {
    add("record_max_mb " + std::to_string(config.output.record_max_mb));
  }

  const std::lock_guard<std::mutex> lock(mutex_);
  if (new_stream) {
    retire(stream_);
    stream_.lines = std::move(stream);
  }
  if (new_record) {
    retire(record_);
    record_.lines = std::move(record);
    record_bytes_ = 0;
  }
  config_ = config;
  return changed;
}

void RowOutputs::flush() {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (stream_.lines) stream_.lines->flush();
  if (record_.lines) record_.lines->flush();
}

std::uint64_t RowOutputs::lines_dropped() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::uint64_t n = retired_dropped_;
  for (const Sink* s : {&stream_, &record_}) {
    if (s->lines) n += s->lines->lines_dropped();
  }
  return n;
}

std::vector<std::string> RowOutputs::first_errors() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out = retired_errors_;
  for (const Sink* s : {&stream_, &record_}) {
    if (s->lines && !s->lines->first_error().empty()) out.push_back(s->lines->first_error());
  }
  return out;
}

}  // namespace gyrotc::app
