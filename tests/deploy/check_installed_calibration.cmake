# The installed daemon uses the installed calibration: cmake --install into a
# fresh DESTDIR, then the installed gyrotc (through the cross emulator, if any)
#  1. `probe --config <DESTDIR>/etc/gyrotc/gyrotc-sim.toml` names <DESTDIR>/etc/gyrotc/calibration.toml;
#  2. replacing that file with another fitted model (gyrotc fit --method poly) changes the model probe reports;
#  3. a broken calibration file makes `run` exit non-zero naming the file and the line.
cmake_minimum_required(VERSION 3.22)

file(REMOVE_RECURSE "${STAGE}")
set(ENV{DESTDIR} "${STAGE}")
execute_process(COMMAND "${CMAKE_COMMAND}" --install "${BUILD_DIR}" RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}): ${err}")
endif()
unset(ENV{DESTDIR})
unset(ENV{GYROTC_DATA_DIR})

set(gyrotc ${EMULATOR} "${STAGE}${BINDIR}/gyrotc")
set(confdir "${STAGE}${SYSCONFDIR}/gyrotc")
set(calibration "${confdir}/calibration.toml")

# probe --json; sets `detail` to what it says of the calibration.
function(probe_calibration)
  execute_process(COMMAND ${gyrotc} probe --config "${confdir}/gyrotc-sim.toml" --json
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "gyrotc probe exited ${rc}:\n${out}\n${err}")
  endif()
  string(JSON n LENGTH "${out}" devices)
  math(EXPR last "${n} - 1")
  string(JSON device GET "${out}" devices ${last} device)
  string(JSON text GET "${out}" devices ${last} detail)
  if(NOT device STREQUAL "calibration")
    message(FATAL_ERROR "probe's last line is '${device}', not the calibration:\n${out}")
  endif()
  set(detail "${text}" PARENT_SCOPE)
endfunction()

# The model kind the installed file declares (the shipped one is what
# fit --method auto made of Table 2).
file(STRINGS "${calibration}" kind_line REGEX "^kind = ")
string(REGEX REPLACE "^kind = \"([a-z]+)\".*" "\\1" installed_kind "${kind_line}")
probe_calibration()
string(FIND "${detail}" "${calibration}: ${installed_kind}, " at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "probe does not name the installed calibration ${calibration} (a ${installed_kind} model):\n  ${detail}")
endif()
message(STATUS "1. ${detail}")

execute_process(COMMAND ${gyrotc} fit --data "${STAGE}${DATADIR}/gyrotc/table2_zero_bias.csv" --method poly
                        --out "${calibration}"
  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "gyrotc fit --method poly failed (${rc}): ${err}")
endif()
probe_calibration()
string(FIND "${detail}" "${calibration}: polynomial, " at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "after installing a polynomial calibration probe still says:\n  ${detail}")
endif()
message(STATUS "2. ${detail}")

file(WRITE "${calibration}" "format = \"gyrotc-calibration\"\nversion = 1\nkind = 7\n")
execute_process(COMMAND ${gyrotc} run --config "${confdir}/gyrotc-sim.toml" --duration 1 --allow-non-rt
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
string(FIND "${err}" "${calibration}:3" at)
if(rc EQUAL 0 OR at EQUAL -1)
  message(FATAL_ERROR "run with a broken calibration exited ${rc}, saying:\n${err}")
endif()
string(STRIP "${err}" err)
message(STATUS "3. run exited ${rc}: ${err}")
