# Cross build for 32-bit ARM hard-float (armhf: BeagleBone Black, Pi 2/3
# 32-bit images) with Debian's cross compiler and multiarch libraries:
#   dpkg --add-architecture armhf && apt-get update
#   apt-get install g++-arm-linux-gnueabihf qemu-user \
#     libgpiod-dev:armhf libtomlplusplus-dev:armhf libbenchmark-dev:armhf
# Tests run under qemu-arm through CMAKE_CROSSCOMPILING_EMULATOR.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(GYROTC_TRIPLE arm-linux-gnueabihf)
include(${CMAKE_CURRENT_LIST_DIR}/debian-multiarch-common.cmake)
