# Under qemu-user (cross builds) the tests that start the runner's threads
# (in process, or a `gyrotc run` child) and a bare SCHED_FIFO RealtimeThread
# (when permitted, e.g. as root) hang on qemu 7.2 (observed: the
# real-time simulated-board run spins at 100 % CPU and never ends), so they
# are compiled natively only; see tests/hal/sim/link.cmake. The root cause is
# qemu's, not ours: on qemu-aarch64 7.2.22 (bookworm) a guest thread spinning
# on an atomic, even with sched_yield() in the loop, keeps a newly started
# thread from ever running (8 lines: a release store loop in a std::thread,
# an acquire spin in main; user time shows one busy core).
if(CMAKE_CROSSCOMPILING)
  target_compile_definitions(${exe} PRIVATE GYROTC_NO_GUEST_THREADS=1)
endif()
