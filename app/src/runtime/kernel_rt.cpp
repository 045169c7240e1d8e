#include "gyrotc/app/runtime/kernel_rt.hpp"

#include <sys/utsname.h>

#include <fstream>
#include <string>

namespace gyrotc::app {

KernelRealtime kernel_realtime(std::string_view sys_kernel_realtime, std::string_view uname_version) {
  if (!sys_kernel_realtime.empty() && sys_kernel_realtime.front() == '1') {
    return {true, "/sys/kernel/realtime = 1"};
  }
  if (uname_version.find("PREEMPT_RT") != std::string_view::npos) {
    return {true, "uname -v: " + std::string(uname_version)};
  }
  return {false, "no /sys/kernel/realtime, uname -v: " + std::string(uname_version)};
}

KernelRealtime running_kernel_realtime() {
  std::string flag;
  std::ifstream("/sys/kernel/realtime") >> flag;
  utsname u{};
  const std::string version = ::uname(&u) == 0 ? u.version : "";
  return kernel_realtime(flag, version);
}

}  // namespace gyrotc::app
