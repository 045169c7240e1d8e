# The ptest package as it sits on a target: cmake --install --strip of the
# default and the ptest components into a fresh DESTDIR (what the Yocto
# recipe's do_install and do_install_ptest install), then
#  1. no installed file names the build or the source tree (Yocto's buildpaths QA);
#  2. every staged test executable starts there (--help), and run-ptest
#     from the staged tree, with only the staged gyrotc on PATH and no GYROTC_*
#     variable, passes every test executable (native builds; a cross build
#     cannot run them here and says so). In a sanitizer build, which is slow and
#     whose executables the build tree's run has just passed, each thing the
#     tree provides (tests/support/test_paths.hpp) is used once: run-ptest
#     runs one short executable each for the seed's data, the example
#     configurations and the data folder's lookup, and the staged
#     test_app_daemon runs its one case that starts the gyrotc on PATH. A
#     name that no longer exists fails.
cmake_minimum_required(VERSION 3.22)

include(${CMAKE_CURRENT_LIST_DIR}/install_paths.cmake)
rel_or_abs(ptest "${PTEST_DIR}")

file(REMOVE_RECURSE "${STAGE}")
set(ENV{DESTDIR} "${STAGE}")
foreach(component "" ptest)
  set(args --install "${BUILD_DIR}" --strip)
  if(component)
    list(APPEND args --component ${component})
  endif()
  execute_process(COMMAND "${CMAKE_COMMAND}" ${args} RESULT_VARIABLE rc ERROR_VARIABLE err OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "cmake ${args} failed (${rc}): ${err}")
  endif()
endforeach()
unset(ENV{DESTDIR})

file(GLOB tests "${STAGE}${ptest}/tests/test_*")
list(LENGTH tests n)
if(n EQUAL 0 OR NOT EXISTS "${STAGE}${ptest}/run-ptest" OR NOT EXISTS "${STAGE}${ptest}/config/calibration.toml"
   OR NOT EXISTS "${STAGE}${ptest}/share/gyrotc/table2_zero_bias.csv")
  message(FATAL_ERROR "the ptest tree under ${STAGE}${ptest} is incomplete (${n} test executables)")
endif()

file(GLOB_RECURSE installed "${STAGE}/*")
if(SANITIZE)
  # UBSan keeps each check's source file name in the binary; a product build has none.
  message(STATUS "build paths not checked: a sanitizer build names its sources in its checks "
                 "(a Release build, e.g. the aarch64 one, checks them)")
  set(installed "")
endif()
foreach(f IN LISTS installed)
  if(IS_SYMLINK "${f}")
    continue()
  endif()
  file(STRINGS "${f}" hits REGEX "${BUILD_DIR}|${SOURCE_DIR}/")
  if(hits)
    list(GET hits 0 first)
    message(FATAL_ERROR "${f} names a build machine path: ${first}")
  endif()
endforeach()
list(LENGTH installed files)
if(files GREATER 0)
  message(STATUS "no build or source path in the ${files} installed files")
endif()

if(CROSSCOMPILING)
  message(STATUS "SKIPPED: run-ptest not run: a cross build's test executables run on the target")
  return()
endif()
set(ENV{PATH} "${STAGE}${BINDIR}:/usr/bin:/bin")
foreach(var GYROTC_EXE GYROTC_TEST_ROOT GYROTC_DATA_DIR)
  unset(ENV{${var}})
endforeach()
set(run "")
if(SANITIZE)
  set(run test_app_identify test_app_probe test_app_data_dir)
endif()
foreach(t IN LISTS tests)
  execute_process(COMMAND "${t}" --help WORKING_DIRECTORY / RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${t} --help exited ${rc} in the staged tree: ${err}")
  endif()
  if(NOT SANITIZE)
    get_filename_component(name "${t}" NAME)
    list(APPEND run "${name}")
  endif()
endforeach()
list(LENGTH run n)
execute_process(COMMAND "${STAGE}${ptest}/run-ptest" ${run} WORKING_DIRECTORY /
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(REGEX MATCHALL "PASS: [^\n]+" passed "${out}")
list(LENGTH passed n_passed)
if(NOT rc EQUAL 0 OR NOT n_passed EQUAL n)
  message(FATAL_ERROR "run-ptest exited ${rc}, ${n_passed} of ${n} passed:\n${out}\n${err}")
endif()
# A board's ptest leaves the statistical sweeps out (minutes each here, and
# many times that on a board), and says so.
if(NOT out MATCHES "run-ptest: the statistical sweeps \\(\\[sweep\\]\\) are left out")
  message(FATAL_ERROR "run-ptest did not say it left the sweeps out:\n${out}")
endif()
list(LENGTH tests n_all)
message(STATUS "run-ptest in ${STAGE}${ptest}: ${n_passed}/${n} PASS (${n_all} executables started)")
if(SANITIZE)
  # The gyrotc on PATH, started by the staged tree's own test. The output must
  # say one case ran: a name that matches nothing is not a pass.
  set(case "SIGTERM to a running*")
  execute_process(COMMAND "${STAGE}${ptest}/tests/test_app_daemon" "${case}" WORKING_DIRECTORY /
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "1 test case")
    message(FATAL_ERROR "staged test_app_daemon \"${case}\" exited ${rc}:\n${out}\n${err}")
  endif()
  message(STATUS "staged test_app_daemon \"${case}\": passed, with the staged gyrotc on PATH")
endif()
