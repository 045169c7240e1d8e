#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <thread>
#include <vector>

#include "gyrotc/emu/event_log.hpp"
#include "gyrotc/emu/w1_bus.hpp"
#include "gyrotc/hal/clock.hpp"

struct fuse_session;
struct fuse_req;

// A W1Bus mounted (FUSE) at a w1_root folder: one folder per DS18B20
// ("28-..."), w1_bus_master1 beside them, each with w1_therm's attributes.
// A read of a converting attribute is answered when the conversion is done
// (another thread replies), as the kernel's read blocks; every open file
// reads its content once (sysfs keeps it per open file); nothing is cached
// by the kernel (entries, attributes, pages), so an unplugged sensor's folder
// goes when the bus's search removes it. Mounted with allow_other (the
// daemon runs as its own user).
namespace gyrotc::emu {

class W1Filesystem {
 public:
  // Mounts at root (created if missing and not under /sys). Throws
  // app::RuntimeFailure naming the folder.
  W1Filesystem(std::string root, std::shared_ptr<W1Bus> bus, EventLog& log, hal::Clock& clock);
  ~W1Filesystem();
  W1Filesystem(const W1Filesystem&) = delete;
  W1Filesystem& operator=(const W1Filesystem&) = delete;

  void start();
  void stop() noexcept;
  const std::string& root() const noexcept { return root_; }

  // For the FUSE callbacks.
  struct Handle {
    std::string id;
    W1Attribute attribute;
    bool read = false;
    std::string content;
  };
  W1Bus& bus() noexcept { return *bus_; }
  hal::Clock& clock() noexcept { return clock_; }
  EventLog& log() noexcept { return log_; }
  std::uint64_t open_handle(Handle handle);
  Handle* handle(std::uint64_t fh);
  void close_handle(std::uint64_t fh);
  // Replies with `data` (from offset 0) at ready_s, on the reply thread.
  void reply_at(double ready_s, fuse_req* req, std::string data);

 private:
  void run_replies();

  std::string root_;
  std::shared_ptr<W1Bus> bus_;
  EventLog& log_;
  hal::Clock& clock_;
  fuse_session* session_ = nullptr;
  bool mounted_ = false;
  std::thread thread_, reply_thread_;

  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::map<std::uint64_t, Handle> handles_;
  std::uint64_t next_handle_ = 1;
  struct Pending {
    double ready_s;
    fuse_req* req;
    std::string data;
    bool operator>(const Pending& o) const { return ready_s > o.ready_s; }
  };
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> pending_;
};

}  // namespace gyrotc::emu
