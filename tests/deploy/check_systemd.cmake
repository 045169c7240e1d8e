# systemd-analyze on the unit as installed (tests/deploy/check_install.cmake stages it).
#   CHECK=verify    `systemd-analyze verify` must succeed and print nothing (it only
#                   warns, exit 0, on unknown keys); ExecStart points at the staged binary,
#                   since verify checks that the command exists.
#   CHECK=security  `systemd-analyze security --offline=true` must rate <= MAX_EXPOSURE.
cmake_minimum_required(VERSION 3.22)

find_program(SYSTEMD_ANALYZE systemd-analyze)
if(NOT SYSTEMD_ANALYZE)
  message("SKIPPED: systemd-analyze not found (Debian package 'systemd'); the unit was not checked")
  return()
endif()

if(IS_ABSOLUTE "${UNITDIR}")
  set(unit "${STAGE}${UNITDIR}/gyrotc.service")
else()
  set(unit "${STAGE}${PREFIX}/${UNITDIR}/gyrotc.service")
endif()
if(NOT EXISTS "${unit}")
  message(FATAL_ERROR "${unit} missing: run deploy/install_tree first")
endif()
set(work "${STAGE}-${CHECK}")
file(REMOVE_RECURSE "${work}")
file(MAKE_DIRECTORY "${work}")
file(READ "${unit}" text)
string(REPLACE "${BINDIR}/gyrotc" "${STAGE}${BINDIR}/gyrotc" text "${text}")
file(WRITE "${work}/gyrotc.service" "${text}")

if(CHECK STREQUAL "verify")
  execute_process(COMMAND "${SYSTEMD_ANALYZE}" verify --man=no "${work}/gyrotc.service"
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(STRIP "${out}${err}" said)
  if(NOT rc EQUAL 0 OR NOT said STREQUAL "")
    message(FATAL_ERROR "systemd-analyze verify (exit ${rc}):\n${said}")
  endif()
  message(STATUS "systemd-analyze verify: gyrotc.service OK")
elseif(CHECK STREQUAL "security")
  execute_process(COMMAND "${SYSTEMD_ANALYZE}" security --offline=true --no-pager "${work}/gyrotc.service"
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT "${out}${err}" MATCHES "Overall exposure level for gyrotc.service: ([0-9]+\\.[0-9]+)")
    if("${err}" MATCHES "offline")  # systemd < 250 has no --offline
      message("SKIPPED: this systemd-analyze has no --offline security mode:\n${err}")
      return()
    endif()
    message(FATAL_ERROR "no exposure level in systemd-analyze output (exit ${rc}):\n${out}\n${err}")
  endif()
  set(level "${CMAKE_MATCH_1}")
  if(level GREATER MAX_EXPOSURE)
    message(FATAL_ERROR "gyrotc.service exposure ${level} > ${MAX_EXPOSURE}:\n${out}")
  endif()
  message(STATUS "systemd-analyze security: gyrotc.service exposure ${level} (limit ${MAX_EXPOSURE})")
else()
  message(FATAL_ERROR "CHECK=${CHECK}: expected verify or security")
endif()
