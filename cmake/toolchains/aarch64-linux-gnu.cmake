# Cross build for 64-bit ARM (aarch64) with Debian's cross compiler and
# multiarch libraries:
#   dpkg --add-architecture arm64 && apt-get update
#   apt-get install g++-aarch64-linux-gnu qemu-user \
#     libgpiod-dev:arm64 libtomlplusplus-dev:arm64 libbenchmark-dev:arm64
# Header-only dependencies (Eigen, CLI11, nlohmann-json; Catch2 2 on Debian 12)
# come from the native packages; Catch2 3 (Debian 13) from build/cross-deps/,
# where scripts/deps.sh aarch64 unpacks it. Tests run under qemu-aarch64 through
# CMAKE_CROSSCOMPILING_EMULATOR, so plain `ctest` works.
#
# A Yocto SDK does not use this file: source the SDK's environment script and
# configure with its OEToolchainConfig.cmake (see docs/GUIDE.md, "Cross-building").
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(GYROTC_TRIPLE aarch64-linux-gnu)
include(${CMAKE_CURRENT_LIST_DIR}/debian-multiarch-common.cmake)
