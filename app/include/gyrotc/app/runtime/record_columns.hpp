#pragma once

// The columns of the board's record, `gyrotc record`'s CSV (also its header
// line): what `gyrotc fit` and `gyrotc tune` read (time_s, sensor_c, gyro_mv,
// tec_a, ...). The real-time runner's OutputRow and the lockstep runner's
// write_board_record_csv both write it, so the simulator's records read as
// the board's.
namespace gyrotc::app {

inline constexpr const char* kRecordCsvHeader =
    "time_s,sensor_c,ambient_c,gyro_mv,rate_dps_compensated,tec_a,setpoint_c,flags";

}  // namespace gyrotc::app
