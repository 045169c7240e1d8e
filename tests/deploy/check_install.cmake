# cmake --install into a fresh staging DESTDIR, then check the documented tree
# (cmake/GyrotcInstall.cmake) and that the installed unit names the installed paths.
cmake_minimum_required(VERSION 3.22)

include(${CMAKE_CURRENT_LIST_DIR}/install_paths.cmake)
rel_or_abs(unitdir "${UNITDIR}")
rel_or_abs(udevdir "${UDEVDIR}")
rel_or_abs(sysusersdir "${SYSUSERSDIR}")

file(REMOVE_RECURSE "${STAGE}")
set(ENV{DESTDIR} "${STAGE}")
execute_process(COMMAND "${CMAKE_COMMAND}" --install "${BUILD_DIR}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}):\n${out}\n${err}")
endif()

set(expected
  "${BINDIR}/gyrotc"
  "${SYSCONFDIR}/gyrotc/gyrotc.toml"
  "${SYSCONFDIR}/gyrotc/gyrotc-sim.toml"
  "${SYSCONFDIR}/gyrotc/calibration.toml"
  "${unitdir}/gyrotc.service"
  "${sysusersdir}/gyrotc.conf"
  "${udevdir}/60-gyrotc.rules"
  "${DATADIR}/gyrotc/table2_zero_bias.csv"
  "${DATADIR}/gyrotc/fig26_chamber_profile.csv"
  "${DATADIR}/gyrotc/README.md"
  "${DOCDIR}/README.md"
  "${DOCDIR}/BOARD-rpi4.md"
  "${DOCDIR}/LICENSE"
  "${DOCDIR}/copyright")
set(missing "")
foreach(f IN LISTS expected)
  if(NOT EXISTS "${STAGE}${f}")
    string(APPEND missing "\n  ${f}")
  endif()
endforeach()
if(missing)
  message(FATAL_ERROR "not installed under DESTDIR=${STAGE}:${missing}")
endif()

if(NOT IS_DIRECTORY "${STAGE}${BINDIR}" OR IS_SYMLINK "${STAGE}${BINDIR}/gyrotc")
  message(FATAL_ERROR "${BINDIR}/gyrotc is not a regular file")
endif()
file(READ "${STAGE}${unitdir}/gyrotc.service" unit)
foreach(line
    "ExecStart=${BINDIR}/gyrotc run --config ${SYSCONFDIR}/gyrotc/gyrotc.toml"
    "ExecReload=/bin/kill -HUP $MAINPID"
    "ExecStopPost=${BINDIR}/gyrotc safe-off --config ${SYSCONFDIR}/gyrotc/gyrotc.toml")
  string(FIND "${unit}" "${line}\n" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "installed unit lacks the line\n  ${line}")
  endif()
endforeach()
file(READ "${STAGE}${SYSCONFDIR}/gyrotc/calibration.toml" cal)
if(NOT cal MATCHES "format = \"gyrotc-calibration\"")
  message(FATAL_ERROR "${SYSCONFDIR}/gyrotc/calibration.toml is not a gyrotc calibration file")
endif()
list(LENGTH expected n)
message(STATUS "install tree OK: ${n} documented files under ${STAGE}")
