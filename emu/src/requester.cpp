#include "gyrotc/emu/requester.hpp"

namespace gyrotc::emu {

namespace {
thread_local int current_pid = 0;
}

int requester_pid() noexcept { return current_pid; }

RequesterScope::RequesterScope(int pid) noexcept : previous_(current_pid) { current_pid = pid; }

RequesterScope::~RequesterScope() { current_pid = previous_; }

}  // namespace gyrotc::emu
