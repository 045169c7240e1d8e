#pragma once

#include <string>
#include <string_view>

namespace gyrotc::app {

// Whether the running kernel is a PREEMPT_RT kernel. On the board the ADS1251's
// DOUT window (907.5 us at 1 kSPS) must be met after every DRDY edge, which a
// kernel without PREEMPT_RT misses under load; `gyrotc run` warns when it is not.
struct KernelRealtime {
  bool preempt_rt = false;
  std::string evidence;  // "/sys/kernel/realtime = 1", "uname -v: ... PREEMPT_RT ...", or why not
};

// From the contents of /sys/kernel/realtime ("" when absent: only PREEMPT_RT
// kernels have it) and the kernel's version string (uname -v).
KernelRealtime kernel_realtime(std::string_view sys_kernel_realtime, std::string_view uname_version);
// The running kernel's.
KernelRealtime running_kernel_realtime();

}  // namespace gyrotc::app
