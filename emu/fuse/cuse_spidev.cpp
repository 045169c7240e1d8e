#define FUSE_USE_VERSION 31
#include "cuse_spidev.hpp"

#include <cuse_lowlevel.h>
#include <fuse_lowlevel.h>
#include <signal.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "gyrotc/app/support/errors.hpp"
#include "gyrotc/emu/requester.hpp"

namespace gyrotc::emu {

namespace {

CuseSpidev& device_of(fuse_req_t req) { return *static_cast<CuseSpidev*>(fuse_req_userdata(req)); }

void on_open(fuse_req_t req, fuse_file_info* fi) {
  device_of(req).note("open", fuse_req_ctx(req)->pid);
  fi->nonseekable = 1;
  fi->direct_io = 1;
  fuse_reply_open(req, fi);
}

void on_release(fuse_req_t req, fuse_file_info*) {
  device_of(req).note("release", fuse_req_ctx(req)->pid);
  fuse_reply_err(req, 0);
}

void on_read(fuse_req_t req, size_t size, off_t, fuse_file_info*) {
  const RequesterScope requester(fuse_req_ctx(req)->pid);
  std::vector<std::uint8_t> rx(size);
  const int n = device_of(req).endpoint().read(rx);
  if (n < 0) {
    fuse_reply_err(req, -n);
  } else {
    fuse_reply_buf(req, reinterpret_cast<const char*>(rx.data()), static_cast<size_t>(n));
  }
}

void on_write(fuse_req_t req, const char* buf, size_t size, off_t, fuse_file_info*) {
  const RequesterScope requester(fuse_req_ctx(req)->pid);
  const int n = device_of(req).endpoint().write(
      std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(buf), size));
  if (n < 0) {
    fuse_reply_err(req, -n);
  } else {
    fuse_reply_write(req, static_cast<size_t>(n));
  }
}

std::vector<iovec> iovecs(const std::vector<UserRange>& ranges) {
  std::vector<iovec> out;
  out.reserve(ranges.size());
  for (const UserRange& r : ranges) {
    // Addresses of the caller's memory: only handed back to the kernel.
    out.push_back({reinterpret_cast<void*>(static_cast<std::uintptr_t>(r.address)), r.size});
  }
  return out;
}

void on_ioctl(fuse_req_t req, int cmd, void* arg, fuse_file_info*, unsigned flags, const void* in_buf,
              size_t in_bufsz, size_t out_bufsz) {
  (void)flags;
  const RequesterScope requester(fuse_req_ctx(req)->pid);
  const IoctlCall call{static_cast<unsigned>(cmd), reinterpret_cast<std::uintptr_t>(arg),
                       std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(in_buf), in_bufsz), out_bufsz};
  const IoctlReply reply = device_of(req).endpoint().ioctl(call);
  switch (reply.kind) {
    case IoctlReply::Kind::retry: {
      const std::vector<iovec> in = iovecs(reply.in), out = iovecs(reply.out);
      fuse_reply_ioctl_retry(req, in.empty() ? nullptr : in.data(), in.size(), out.empty() ? nullptr : out.data(),
                             out.size());
      return;
    }
    case IoctlReply::Kind::done:
      fuse_reply_ioctl(req, reply.result, reply.data.empty() ? nullptr : reply.data.data(), reply.data.size());
      return;
    case IoctlReply::Kind::error: fuse_reply_err(req, reply.error); return;
  }
}

const cuse_lowlevel_ops kCuseOps = [] {
  cuse_lowlevel_ops ops{};
  ops.open = on_open;
  ops.read = on_read;
  ops.write = on_write;
  ops.release = on_release;
  ops.ioctl = on_ioctl;
  return ops;
}();

void do_nothing(int) {}

}  // namespace

void install_session_wakeup() {
  struct sigaction sa {};
  sa.sa_handler = do_nothing;  // no SA_RESTART: the blocked read returns EINTR
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, nullptr);
}

void wake_session_thread(std::thread& thread) noexcept {
  if (thread.joinable()) pthread_kill(thread.native_handle(), SIGUSR1);
}

CuseSpidev::CuseSpidev(const std::string& path, SpidevEndpoint& endpoint, EventLog& log, hal::Clock& clock)
    : path_(path), endpoint_(endpoint), log_(log), clock_(clock) {
  if (path_.rfind("/dev/", 0) != 0 || path_.size() <= 5) {
    throw app::InputError("spidev path '" + path_ + "': CUSE creates nodes under /dev only");
  }
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0) {
    throw app::RuntimeFailure("'" + path_ + "' exists already (a real spidev, or another gyrotc-emu): the emulator "
                              "creates its own node there");
  }
  if (::stat("/dev/cuse", &st) != 0) {
    throw app::RuntimeFailure("no /dev/cuse: load the module (modprobe cuse); creating a CUSE device needs root");
  }
  devname_arg_ = "DEVNAME=" + path_.substr(5);
  const char* dev_info[] = {devname_arg_.c_str()};
  cuse_info ci{};
  ci.dev_info_argc = 1;
  ci.dev_info_argv = dev_info;
  ci.flags = CUSE_UNRESTRICTED_IOCTL;
  char arg0[] = "gyrotc-emu", arg1[] = "-f", arg2[] = "-s";
  char* argv[] = {arg0, arg1, arg2, nullptr};
  int multithreaded = 0;
  session_ = cuse_lowlevel_setup(3, argv, &ci, &kCuseOps, &multithreaded, this);
  if (session_ == nullptr) throw app::RuntimeFailure("cannot create the CUSE device '" + path_ + "' (see above)");
  // Signals are the emulator's own business (its main thread waits for them).
  fuse_remove_signal_handlers(session_);
}

CuseSpidev::~CuseSpidev() {
  stop();
  if (session_ != nullptr) fuse_session_destroy(session_);  // closes /dev/cuse: the node goes
}

void CuseSpidev::start() {
  thread_ = std::thread([this] { fuse_session_loop(session_); });
}

void CuseSpidev::stop() noexcept {
  if (!thread_.joinable()) return;
  fuse_session_exit(session_);
  wake_session_thread(thread_);
  thread_.join();
}

void CuseSpidev::note(const char* what, int pid) {
  log_.add(clock_.now_s(), "spi", path_, what, "pid=" + std::to_string(pid));
}

}  // namespace gyrotc::emu
