#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gyrotc/app/daemon/config.hpp"
#include "gyrotc/app/daemon/line_sink.hpp"
#include "gyrotc/app/runtime/realtime_runner.hpp"

// The daemon's rows as text: the line stream ([output] stream: stdout, a
// file, a serial port) and the CSV record ([output] record_csv, or `record
// --out`), which rotates past record_max_mb. The output thread writes the
// rows; a reload (SIGHUP) replaces what changed from the main thread, between
// two rows: no row is lost or written half, a record that did not change goes
// on in the same file, and the real-time thread never takes the lock.
namespace gyrotc::app {

struct RowOutputsConfig {
  OutputConfig output;                          // stream, path, baud, record_csv, record_max_mb, write_timeout_s
  bool stream = true;                           // false: no stream, whatever output.stream says
  bool rotate = true;                           // false: the record is never cut (`record --out`)
  std::string record_key = "output.record_csv"; // the option named in messages
};

class RowOutputs {
 public:
  // Checks the paths and opens the stream and the record; throws
  // InputError/RuntimeFailure naming the key and the path.
  explicit RowOutputs(const RowOutputsConfig& config);

  // The output thread: one row to the stream (every row) and the record
  // (rows with a casing reading and samples: what a calibration needs). The
  // header goes first into every new stream and file.
  void write(const OutputRow& row);

  // A reload: opens what changed before touching anything (a failure throws
  // and leaves everything as it was), then swaps it in. Returns what changed
  // in words ("" when nothing did).
  std::string reconfigure(const RowOutputsConfig& config);

  // At the end: flushes, then the lines dropped by every sink this object
  // ever had, and their first write errors.
  void flush();
  std::uint64_t lines_dropped() const;
  std::vector<std::string> first_errors() const;

 private:
  struct Sink {
    std::unique_ptr<LineSink> lines;
    bool header_written = false;
  };
  void retire(Sink& sink);  // under the lock
  void rotate_record();     // under the lock

  RowOutputsConfig config_;
  mutable std::mutex mutex_;
  Sink stream_;
  Sink record_;
  std::uint64_t record_bytes_ = 0;
  std::uint64_t retired_dropped_ = 0;
  std::vector<std::string> retired_errors_;
};

}  // namespace gyrotc::app
