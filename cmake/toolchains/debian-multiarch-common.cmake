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
  # -L: the target's dynamic loader and libc from Debian's cross libc package;
  # multiarch libraries (/usr/lib/<triple>) are found through the host path.
  set(CMAKE_CROSSCOMPILING_EMULATOR "${GYROTC_QEMU};-L;/usr/${GYROTC_TRIPLE}")
else()
  message(WARNING "${_gyrotc_qemu} not found (Debian package qemu-user): "
                  "the ${GYROTC_TRIPLE} tests can be built but not run here.")
endif()
