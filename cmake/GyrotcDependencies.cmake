# Finds every third-party dependency. A missing one stops configure with the
# Debian package that provides it (for a cross build: the :arm64 / :armhf
# multiarch variant of the same package).

if(CMAKE_CROSSCOMPILING AND CMAKE_LIBRARY_ARCHITECTURE MATCHES "aarch64")
  set(_gyrotc_pkg_arch ":arm64")
elseif(CMAKE_CROSSCOMPILING AND CMAKE_LIBRARY_ARCHITECTURE MATCHES "arm-linux-gnueabihf")
  set(_gyrotc_pkg_arch ":armhf")
else()
  set(_gyrotc_pkg_arch "")
endif()

function(gyrotc_missing what debian_package)
  message(FATAL_ERROR
    "gyrotc: ${what} not found. Install the Debian package '${debian_package}' "
    "(apt-get install ${debian_package}), or run scripts/deps.sh.")
endfunction()

find_package(Eigen3 3.3 QUIET NO_MODULE)
if(NOT TARGET Eigen3::Eigen)
  gyrotc_missing("Eigen3 (>= 3.3)" "libeigen3-dev")
endif()

find_package(PkgConfig QUIET)
if(NOT PKG_CONFIG_FOUND)
  gyrotc_missing("pkg-config" "pkg-config")
endif()
pkg_check_modules(GPIOD QUIET IMPORTED_TARGET libgpiod)
if(NOT GPIOD_FOUND)
  gyrotc_missing("libgpiod" "libgpiod-dev${_gyrotc_pkg_arch}")
endif()
# Both libgpiod APIs are supported (hal/src/linux/gpiod_line_v1.cpp, _v2.cpp):
# 1.6 on Debian 12 and Yocto with PREFERRED_VERSION_libgpiod = "1.6%", 2.x on
# Debian 13 / Raspberry Pi OS and meta-oe's default from scarthgap on.
if(GPIOD_VERSION VERSION_LESS 1.6)
  message(FATAL_ERROR "gyrotc: libgpiod ${GPIOD_VERSION} is too old; 1.6 or later is required.")
elseif(GPIOD_VERSION VERSION_LESS 2.0)
  set(GYROTC_GPIOD_API 1)
elseif(GPIOD_VERSION VERSION_LESS 3.0)
  set(GYROTC_GPIOD_API 2)
else()
  message(FATAL_ERROR "gyrotc: libgpiod ${GPIOD_VERSION} found; gyrotc knows the 1.6 and 2.x APIs.")
endif()
message(STATUS "gyrotc: libgpiod ${GPIOD_VERSION} (API v${GYROTC_GPIOD_API})")

find_package(CLI11 QUIET CONFIG)
if(NOT TARGET CLI11::CLI11)
  gyrotc_missing("CLI11" "libcli11-dev")
endif()

find_package(tomlplusplus QUIET CONFIG)
if(NOT TARGET tomlplusplus::tomlplusplus)
  gyrotc_missing("toml++ (tomlplusplus)" "libtomlplusplus-dev${_gyrotc_pkg_arch}")
endif()

find_package(nlohmann_json 3.9 QUIET CONFIG)
if(NOT TARGET nlohmann_json::nlohmann_json)
  gyrotc_missing("nlohmann_json (>= 3.9)" "nlohmann-json3-dev")
endif()

find_package(Threads REQUIRED)

# The board emulator (emu/, docs/EMULATOR.md): a separate executable, never
# part of gyrotc. AUTO builds it when libfuse3 (CUSE and FUSE) is found.
set(GYROTC_EMU "AUTO" CACHE STRING "Build gyrotc-emu: AUTO (when libfuse3 is found), ON or OFF")
set_property(CACHE GYROTC_EMU PROPERTY STRINGS AUTO ON OFF)
set(GYROTC_BUILD_EMU OFF)
if(NOT GYROTC_EMU STREQUAL "OFF")
  pkg_check_modules(FUSE3 QUIET IMPORTED_TARGET fuse3)
  if(FUSE3_FOUND)
    set(GYROTC_BUILD_EMU ON)
    message(STATUS "gyrotc: libfuse3 ${FUSE3_VERSION}: gyrotc-emu is built")
  elseif(GYROTC_EMU STREQUAL "ON")
    gyrotc_missing("libfuse3 (GYROTC_EMU=ON)" "libfuse3-dev${_gyrotc_pkg_arch}")
  else()
    message(STATUS "gyrotc: libfuse3 not found: gyrotc-emu is not built (apt-get install "
                   "libfuse3-dev${_gyrotc_pkg_arch})")
  endif()
endif()

# READY=1 / WATCHDOG=1 for the Type=notify unit. gyrotc speaks the sd_notify
# datagram protocol itself (app/src/daemon/systemd_notify.cpp): no libsystemd,
# so cross builds (whose libsystemd-dev:arm64 does not co-install on bookworm)
# get it too.
option(GYROTC_SYSTEMD_NOTIFY "Send sd_notify messages (READY, WATCHDOG, STOPPING) to \$NOTIFY_SOCKET" ON)

if(GYROTC_BUILD_TESTS)
  # Catch2 2 (Debian 12, header-only) or 3 (Debian 13, Yocto walnascar).
  find_package(Catch2 QUIET)
  if(NOT Catch2_FOUND)
    gyrotc_missing("Catch2 (GYROTC_BUILD_TESTS=ON)" "catch2 (Debian 12) or libcatch2-dev (Debian 13)")
  endif()
  # Catch2 3 is a compiled library: a cross build must not link the build
  # machine's (Debian installs it at /usr/lib, for one architecture only).
  if(CMAKE_CROSSCOMPILING AND Catch2_VERSION VERSION_GREATER_EQUAL 3 AND Catch2_DIR MATCHES "^/usr/lib/cmake")
    message(FATAL_ERROR
      "gyrotc: found Catch2 ${Catch2_VERSION} of the build machine (${Catch2_DIR}), which a "
      "${CMAKE_SYSTEM_PROCESSOR} build cannot link. Run scripts/deps.sh aarch64 (or armhf): it unpacks "
      "the target's libcatch2-dev under build/cross-deps/, or pass -DGYROTC_BUILD_TESTS=OFF.")
  endif()
endif()

if(GYROTC_BUILD_BENCH)
  find_package(benchmark QUIET CONFIG)
  if(NOT TARGET benchmark::benchmark)
    gyrotc_missing("Google Benchmark (GYROTC_BUILD_BENCH=ON)" "libbenchmark-dev${_gyrotc_pkg_arch}")
  endif()
endif()
