# Shared part of the Debian cross toolchain files; GYROTC_TRIPLE and
# CMAKE_SYSTEM_PROCESSOR are set by the including file.
set(CMAKE_C_COMPILER ${GYROTC_TRIPLE}-gcc)
set(CMAKE_CXX_COMPILER ${GYROTC_TRIPLE}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${GYROTC_TRIPLE})

# Libraries and CMake package files of the target come from the multiarch
# directory /usr/lib/<triple>; headers from /usr/include. Programs (pkg-config,
# qemu) are the build machine's.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${GYROTC_TRIPLE}/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

if(CMAKE_SYSTEM_PROCESSOR STREQUAL "aarch64")
  set(_gyrotc_qemu qemu-aarch64)
else()
  set(_gyrotc_qemu qemu-arm)
endif()
find_program(GYROTC_QEMU ${_gyrotc_qemu})
if(GYROTC_QEMU)
  # No -L: the target's dynamic loader (/lib/ld-linux-*.so) and libc come from
  # the multiarch libc6:<arch> the cross libraries depend on, the same build
  # of glibc as every other library the binary loads.
  set(CMAKE_CROSSCOMPILING_EMULATOR "${GYROTC_QEMU}")
else()
  message(WARNING "${_gyrotc_qemu} not found (Debian package qemu-user): "
                  "the ${GYROTC_TRIPLE} tests can be built but not run here.")
endif()

# Catch2 3 (Debian 13) installs its static libraries without a multiarch path,
# so the target's cannot sit beside the build machine's: scripts/deps.sh
# unpacks libcatch2-dev:<arch> under build/cross-deps/<arch>.
if(GYROTC_TRIPLE MATCHES "^aarch64")
  set(_gyrotc_deb_arch arm64)
else()
  set(_gyrotc_deb_arch armhf)
endif()
set(_gyrotc_cross_catch2 "${CMAKE_CURRENT_LIST_DIR}/../../build/cross-deps/${_gyrotc_deb_arch}/usr/lib/cmake/Catch2")
if(EXISTS "${_gyrotc_cross_catch2}/Catch2Config.cmake")
  get_filename_component(_gyrotc_cross_catch2 "${_gyrotc_cross_catch2}" ABSOLUTE)
  set(Catch2_DIR "${_gyrotc_cross_catch2}" CACHE PATH "Catch2 for ${GYROTC_TRIPLE} (scripts/deps.sh)")
endif()
