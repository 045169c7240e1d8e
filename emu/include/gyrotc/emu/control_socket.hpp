#pragma once

#include <atomic>
#include <functional>
#include <string>
#include <thread>

// The emulator's command interface: a UNIX stream socket; a client sends one
// line ("fault casing disconnect", "status", ...), the server answers one
// line ("ok ..." or "error: ...") and closes. The commands are
// BoardEmulator::apply's (gyrotc-emu ctl --help lists them).
namespace gyrotc::emu {

class ControlServer {
 public:
  using Handler = std::function<std::string(const std::string& command)>;
  // Binds path (a stale socket file is replaced; mode 0660) and serves on a
  // thread of its own. Throws app::RuntimeFailure naming the path.
  ControlServer(std::string path, Handler handler);
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;
  const std::string& path() const noexcept { return path_; }

 private:
  void serve();

  std::string path_;
  Handler handler_;
  int fd_ = -1;
  int wake_[2] = {-1, -1};
  std::thread thread_;
};

// Sends one command and returns the answer line. Throws app::RuntimeFailure
// when nothing listens at path (the emulator is not running).
std::string control_request(const std::string& path, const std::string& command, double timeout_s = 10.0);

}  // namespace gyrotc::emu
