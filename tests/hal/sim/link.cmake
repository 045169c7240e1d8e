# Under qemu-user (cross builds) creating a thread in the guest hangs on the
# Debian bookworm qemu 7.2 of this project's machines (even a bare
# std::thread), so the one two-thread real-time test is compiled natively only.
if(CMAKE_CROSSCOMPILING)
  target_compile_definitions(${exe} PRIVATE GYROTC_NO_GUEST_THREADS=1)
endif()
