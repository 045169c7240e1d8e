#include "gyrotc/hal/linux/device_lock.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "gyrotc/hal/linux/spidev_bus.hpp"
#include "gyrotc_catch.hpp"

using namespace gyrotc::hal;
namespace fs = std::filesystem;

namespace {

// A file standing in for a device node (flock works the same on both).
struct FakeNode {
  fs::path path = fs::temp_directory_path() / ("gyrotc-lock-" + std::to_string(::getpid()) + "-" +
                                               std::to_string(reinterpret_cast<std::uintptr_t>(this)));
  FakeNode() { std::ofstream(path) << ""; }
  ~FakeNode() { fs::remove(path); }
};

struct Fd {
  int fd;
  explicit Fd(const fs::path& p) : fd(::open(p.c_str(), O_RDWR | O_CLOEXEC)) { REQUIRE(fd >= 0); }
  ~Fd() { ::close(fd); }
};

std::string own_name() {
  std::ifstream in("/proc/" + std::to_string(::getpid()) + "/comm");
  std::string name;
  std::getline(in, name);
  return name;
}

}  // namespace

TEST_CASE("a device locked through another descriptor is busy, naming the holder's PID and name") {
  FakeNode node;
  Fd first(node.path);
  Fd second(node.path);
  REQUIRE(lock_device(first.fd, node.path.string()).ok());
  const Status s = lock_device(second.fd, node.path.string());
  REQUIRE_FALSE(s.ok());
  CHECK(s.error().code() == ErrorCode::busy);
  char expected[512];
  std::snprintf(expected, sizeof expected, "'%s' is already in use by PID %d (%s)", node.path.c_str(),
                static_cast<int>(::getpid()), own_name().c_str());
  CHECK(std::string(s.error().message()) == expected);
}

TEST_CASE("the lock goes with the descriptor that held it") {
  FakeNode node;
  Fd second(node.path);
  {
    Fd first(node.path);
    REQUIRE(lock_device(first.fd, node.path.string()).ok());
    CHECK_FALSE(lock_device(second.fd, node.path.string()).ok());
  }
  CHECK(lock_device(second.fd, node.path.string()).ok());
}

TEST_CASE("a second SpidevBus on a device in use is refused before any ioctl") {
  FakeNode node;
  auto first = SpidevBus::open(node.path.string());
  REQUIRE(first.ok());
  auto second = SpidevBus::open(node.path.string());
  REQUIRE_FALSE(second.ok());
  CHECK(second.error().code() == ErrorCode::busy);
  CHECK(std::string(second.error().message()).find("already in use by PID " + std::to_string(::getpid())) !=
        std::string::npos);
}

TEST_CASE("the holder is found in a /proc/locks table by device and inode") {
  FakeNode node;
  Fd fd(node.path);
  struct stat st {};
  REQUIRE(::fstat(fd.fd, &st) == 0);
  const fs::path table = node.path.string() + ".locks";
  char line[160];
  std::snprintf(line, sizeof line,
                "1: POSIX  ADVISORY  WRITE 11 %02x:%02x:%llu 0 EOF\n"
                "2: -> FLOCK  ADVISORY  WRITE 22 %02x:%02x:%llu 0 EOF\n"
                "3: FLOCK  ADVISORY  WRITE 4242 %02x:%02x:%llu 0 EOF\n",
                major(st.st_dev), minor(st.st_dev), static_cast<unsigned long long>(st.st_ino), major(st.st_dev),
                minor(st.st_dev), static_cast<unsigned long long>(st.st_ino), major(st.st_dev), minor(st.st_dev),
                static_cast<unsigned long long>(st.st_ino));
  std::ofstream(table) << line;
  const auto holder = flock_holder(fd.fd, table.c_str());
  fs::remove(table);
  REQUIRE(holder.has_value());
  CHECK(*holder == 4242);  // not the POSIX lock's owner, not the waiter
}
