#pragma once

// The columns of the board's record, `gyrotc record`'s CSV (also its header
// line): what `gyrotc fit` and `gyrotc tune` read (time_s, sensor_c, gyro_mv,
// tec_a, ...). The real-time runner's OutputRow and the lockstep runner's
// write_board_record_csv both write it, so the simulator's records read as
// the board's.
#include <cinttypes>
#include <cstddef>
#include <cstdint>
#include <cstdio>

namespace gyrotc::app {

inline constexpr const char* kRecordCsvHeader =
    "time_s,sensor_c,ambient_c,gyro_mv,rate_dps_compensated,tec_a,setpoint_c,flags";

// One row of it, in the same digits from both runners (snprintf's return).
inline int format_record_row(char* out, std::size_t size, double time_s, double sensor_c, double ambient_c,
                             double gyro_mv, double rate_dps, double tec_a, double setpoint_c, std::uint32_t flags) {
  return std::snprintf(out, size, "%.3f,%.4f,%.4f,%.5f,%.6f,%.5f,%.4f,%" PRIu32, time_s, sensor_c, ambient_c, gyro_mv,
                       rate_dps, tec_a, setpoint_c, flags);
}

}  // namespace gyrotc::app
