#pragma once

#include <pthread.h>

#include <string>
#include <thread>

#include "gyrotc/emu/event_log.hpp"
#include "gyrotc/emu/spidev_endpoint.hpp"
#include "gyrotc/hal/clock.hpp"

struct fuse_session;

// One SpidevEndpoint as a character device in user space (CUSE): the kernel
// creates /dev/<name> (class "cuse", its own major: not spidev's), forwards
// open, read, write and ioctl to this process, and fetches and returns the
// ioctl's user memory through the unrestricted-ioctl retries. One thread per
// device runs the FUSE session; stop() ends it and the node goes.
namespace gyrotc::emu {

class CuseSpidev {
 public:
  // path: "/dev/spidev0.0". Throws app::RuntimeFailure (with the hint to load
  // the cuse module when /dev/cuse is missing).
  CuseSpidev(const std::string& path, SpidevEndpoint& endpoint, EventLog& log, hal::Clock& clock);
  ~CuseSpidev();
  CuseSpidev(const CuseSpidev&) = delete;
  CuseSpidev& operator=(const CuseSpidev&) = delete;

  // The session's thread; the node exists once the kernel's INIT is answered.
  void start();
  void stop() noexcept;
  const std::string& path() const noexcept { return path_; }

  // For the FUSE callbacks.
  SpidevEndpoint& endpoint() noexcept { return endpoint_; }
  void note(const char* what, int pid);

 private:
  std::string path_;
  std::string devname_arg_;
  SpidevEndpoint& endpoint_;
  EventLog& log_;
  hal::Clock& clock_;
  fuse_session* session_ = nullptr;
  std::thread thread_;
};

// Installs the no-op SIGUSR1 handler (without SA_RESTART) that stop() uses to
// interrupt a session thread blocked in read(/dev/cuse or /dev/fuse).
void install_session_wakeup();
void wake_session_thread(std::thread& thread) noexcept;

}  // namespace gyrotc::emu
