#pragma once

// The process whose request the emulator is serving on this thread (the
// CUSE request's caller, set by the FUSE glue for the length of one
// request), so the event log can say which process wrote a DAC: the daemon,
// or `gyrotc safe-off` after it. 0: unknown.
namespace gyrotc::emu {

int requester_pid() noexcept;

class RequesterScope {
 public:
  explicit RequesterScope(int pid) noexcept;
  ~RequesterScope();
  RequesterScope(const RequesterScope&) = delete;
  RequesterScope& operator=(const RequesterScope&) = delete;

 private:
  int previous_;
};

}  // namespace gyrotc::emu
