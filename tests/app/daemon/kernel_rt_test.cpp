#include "gyrotc/app/runtime/kernel_rt.hpp"

#include "gyrotc_catch.hpp"

using gyrotc::app::kernel_realtime;

TEST_CASE("a kernel with /sys/kernel/realtime = 1 is PREEMPT_RT") {
  const auto k = kernel_realtime("1\n", "#1 SMP Debian 6.12.38-1");
  CHECK(k.preempt_rt);
  CHECK(k.evidence == "/sys/kernel/realtime = 1");
}

TEST_CASE("a kernel whose version string says PREEMPT_RT is PREEMPT_RT") {
  CHECK(kernel_realtime("", "#1 SMP PREEMPT_RT Debian 6.12.38-1 (2025-07-16)").preempt_rt);
}

TEST_CASE("a PREEMPT (not RT) kernel without the realtime file is not PREEMPT_RT") {
  const auto k = kernel_realtime("", "#1 SMP PREEMPT Debian 1:6.12.34-1+rpt1 (2025-06-26)");
  CHECK_FALSE(k.preempt_rt);
  CHECK(k.evidence == "no /sys/kernel/realtime, uname -v: #1 SMP PREEMPT Debian 1:6.12.34-1+rpt1 (2025-06-26)");
  CHECK_FALSE(kernel_realtime("0", "#1 SMP").preempt_rt);
}
