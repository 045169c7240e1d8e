#include "gyrotc/app/runtime/realtime_thread.hpp"

#include <sched.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "gyrotc/app/support/log.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {
namespace {

// How much of the stack is touched before the loop starts: more than the
// loop's deepest call chain needs (sanitizer builds included).
constexpr std::size_t kPrefaultStackBytes = 128 * 1024;

[[gnu::noinline]] void prefault_stack() noexcept {
  unsigned char pages[kPrefaultStackBytes];
  // Stores through a volatile pointer: they must happen although nobody reads them.
  volatile unsigned char* touch = pages;
  for (std::size_t i = 0; i < kPrefaultStackBytes; i += 4096) touch[i] = 0;
}

class AttrGuard {
 public:
  AttrGuard() { pthread_attr_init(&attr); }
  ~AttrGuard() { pthread_attr_destroy(&attr); }
  AttrGuard(const AttrGuard&) = delete;
  AttrGuard& operator=(const AttrGuard&) = delete;
  pthread_attr_t attr{};
};

void check_options(const RealtimeOptions& options) {
  const int lowest = sched_get_priority_min(SCHED_FIFO);
  const int highest = sched_get_priority_max(SCHED_FIFO);
  if (options.priority < lowest || options.priority > highest) {
    throw InputError("realtime.priority = " + std::to_string(options.priority) + ": SCHED_FIFO priorities are " +
                     std::to_string(lowest) + ".." + std::to_string(highest));
  }
  if (options.cpu) {
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    sched_getaffinity(0, sizeof allowed, &allowed);
    if (*options.cpu < 0 || *options.cpu >= CPU_SETSIZE || !CPU_ISSET(*options.cpu, &allowed)) {
      throw InputError("realtime.cpu = " + std::to_string(*options.cpu) +
                       ": not a CPU this process may use (it may use " + std::to_string(usable_cpu_count()) +
                       " CPUs, numbered from 0)");
    }
  }
}

}  // namespace

int usable_cpu_count() noexcept {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) return 1;
  return CPU_COUNT(&allowed);
}

bool lock_process_memory(const RealtimeOptions& options) {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return true;
  const int err = errno;
  const std::string why = std::string("mlockall failed: ") + std::strerror(err) +
                          " (needs root, CAP_IPC_LOCK or a large enough RLIMIT_MEMLOCK, e.g. "
                          "LimitMEMLOCK=infinity in the unit)";
  if (!options.allow_non_rt) throw RuntimeFailure(why + "; --allow-non-rt runs without it");
  GYROTC_LOG_WARNING("%s; running without locked memory (--allow-non-rt): page faults may delay the loop",
                     why.c_str());
  return false;
}

RealtimeThread::RealtimeThread(const RealtimeOptions& options, std::function<void()> body)
    : body_(std::move(body)) {
  check_options(options);
  AttrGuard rt;
  pthread_attr_setstacksize(&rt.attr, options.stack_bytes);
  pthread_attr_setinheritsched(&rt.attr, PTHREAD_EXPLICIT_SCHED);
  pthread_attr_setschedpolicy(&rt.attr, SCHED_FIFO);
  sched_param param{};
  param.sched_priority = options.priority;
  pthread_attr_setschedparam(&rt.attr, &param);
  if (options.cpu) {
    cpu_set_t cpus;
    CPU_ZERO(&cpus);
    CPU_SET(*options.cpu, &cpus);
    pthread_attr_setaffinity_np(&rt.attr, sizeof cpus, &cpus);
  }
  int err = pthread_create(&thread_, &rt.attr, &RealtimeThread::trampoline, this);
  if (err == 0) {
    realtime_ = true;
    joinable_ = true;
    return;
  }
  const std::string why = "cannot start the real-time thread with SCHED_FIFO priority " +
                          std::to_string(options.priority) + ": " + std::strerror(err) +
                          (err == EPERM ? " (needs root, CAP_SYS_NICE or RLIMIT_RTPRIO >= the priority, e.g. "
                                          "LimitRTPRIO=99 in the unit)"
                                        : "");
  if (err != EPERM || !options.allow_non_rt) {
    throw RuntimeFailure(why + (err == EPERM ? "; --allow-non-rt runs without it" : ""));
  }
  GYROTC_LOG_WARNING("%s; running under the normal scheduler (--allow-non-rt): expect missed samples", why.c_str());
  AttrGuard normal;
  pthread_attr_setstacksize(&normal.attr, options.stack_bytes);
  err = pthread_create(&thread_, &normal.attr, &RealtimeThread::trampoline, this);
  if (err != 0) throw RuntimeFailure(std::string("cannot start the loop thread: ") + std::strerror(err));
  joinable_ = true;
}

RealtimeThread::~RealtimeThread() { join(); }

void RealtimeThread::join() noexcept {
  if (!joinable_) return;
  pthread_join(thread_, nullptr);
  joinable_ = false;
}

void* RealtimeThread::trampoline(void* self) noexcept {
  prefault_stack();
  static_cast<RealtimeThread*>(self)->body_();
  return nullptr;
}

}  // namespace gyrotc::app
