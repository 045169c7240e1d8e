#define FUSE_USE_VERSION 31
#include "w1_filesystem.hpp"

#include <fuse_lowlevel.h>
#include <pthread.h>
#include <sched.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "cuse_spidev.hpp"
#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::emu {

namespace {

// Inodes: 1 the root, 2 w1_bus_master1, 16 + 16 i the folder of the bus's
// i-th sensor and 16 + 16 i + 1 + a its attribute a.
constexpr fuse_ino_t kMaster = 2;
constexpr fuse_ino_t kFirstSensor = 16;
constexpr const char* kMasterName = "w1_bus_master1";

W1Filesystem& fs_of(fuse_req_t req) { return *static_cast<W1Filesystem*>(fuse_req_userdata(req)); }

struct Node {
  enum class Kind { root, master, sensor, attribute, none } kind = Kind::none;
  std::size_t sensor = 0;
  W1Attribute attribute = W1Attribute::w1_slave;
};

Node node_of(W1Filesystem& fs, fuse_ino_t ino) {
  if (ino == FUSE_ROOT_ID) return {Node::Kind::root};
  if (ino == kMaster) return {Node::Kind::master};
  if (ino < kFirstSensor) return {};
  const std::size_t i = (ino - kFirstSensor) / 16, a = (ino - kFirstSensor) % 16;
  if (i >= fs.bus().ids().size()) return {};
  if (a == 0) return {Node::Kind::sensor, i};
  if (a - 1 >= kW1Attributes.size()) return {};
  return {Node::Kind::attribute, i, kW1Attributes[a - 1]};
}

fuse_ino_t sensor_ino(std::size_t i) { return kFirstSensor + 16 * i; }
fuse_ino_t attribute_ino(std::size_t i, W1Attribute a) {
  const auto at = std::find(kW1Attributes.begin(), kW1Attributes.end(), a) - kW1Attributes.begin();
  return sensor_ino(i) + 1 + static_cast<fuse_ino_t>(at);
}

// A node that exists now (a sensor's folder goes when the bus's search drops it).
bool exists(W1Filesystem& fs, const Node& n) {
  switch (n.kind) {
    case Node::Kind::root:
    case Node::Kind::master: return true;
    case Node::Kind::sensor:
    case Node::Kind::attribute: return fs.bus().exists(fs.bus().ids()[n.sensor], fs.clock().now_s());
    case Node::Kind::none: return false;
  }
  return false;
}

struct stat stat_of(const Node& n, fuse_ino_t ino) {
  struct stat st {};
  st.st_ino = ino;
  if (n.kind == Node::Kind::attribute) {
    st.st_mode = S_IFREG | 0444;
    st.st_nlink = 1;
    st.st_size = 4096;  // sysfs attributes report a page
  } else {
    st.st_mode = S_IFDIR | 0755;
    st.st_nlink = 2;
  }
  return st;
}

void reply_entry(fuse_req_t req, const Node& n, fuse_ino_t ino) {
  fuse_entry_param e{};
  e.ino = ino;
  e.attr = stat_of(n, ino);
  e.attr_timeout = 0.0;  // nothing cached: an unplugged sensor's folder goes at once
  e.entry_timeout = 0.0;
  fuse_reply_entry(req, &e);
}

void on_lookup(fuse_req_t req, fuse_ino_t parent, const char* name) {
  W1Filesystem& fs = fs_of(req);
  const Node p = node_of(fs, parent);
  const std::string n = name;
  if (p.kind == Node::Kind::root) {
    if (n == kMasterName) return reply_entry(req, {Node::Kind::master}, kMaster);
    const auto& ids = fs.bus().ids();
    const auto it = std::find(ids.begin(), ids.end(), n);
    if (it != ids.end()) {
      const Node s{Node::Kind::sensor, static_cast<std::size_t>(it - ids.begin())};
      if (exists(fs, s)) return reply_entry(req, s, sensor_ino(s.sensor));
    }
  } else if (p.kind == Node::Kind::sensor && exists(fs, p)) {
    if (const auto a = w1_attribute_named(n)) {
      return reply_entry(req, {Node::Kind::attribute, p.sensor, *a}, attribute_ino(p.sensor, *a));
    }
  }
  fuse_reply_err(req, ENOENT);
}

void on_getattr(fuse_req_t req, fuse_ino_t ino, fuse_file_info*) {
  W1Filesystem& fs = fs_of(req);
  const Node n = node_of(fs, ino);
  if (!exists(fs, n)) return (void)fuse_reply_err(req, ENOENT);
  const struct stat st = stat_of(n, ino);
  fuse_reply_attr(req, &st, 0.0);
}

void on_readdir(fuse_req_t req, fuse_ino_t ino, size_t size, off_t off, fuse_file_info*) {
  W1Filesystem& fs = fs_of(req);
  const Node n = node_of(fs, ino);
  if (!exists(fs, n) || n.kind == Node::Kind::attribute) return (void)fuse_reply_err(req, ENOTDIR);
  std::vector<std::pair<std::string, fuse_ino_t>> entries{{".", ino}, {"..", FUSE_ROOT_ID}};
  if (n.kind == Node::Kind::root) {
    entries.emplace_back(kMasterName, kMaster);
    const auto& ids = fs.bus().ids();
    for (const std::string& id : fs.bus().listed(fs.clock().now_s())) {
      entries.emplace_back(id, sensor_ino(static_cast<std::size_t>(std::find(ids.begin(), ids.end(), id) - ids.begin())));
    }
  } else if (n.kind == Node::Kind::sensor) {
    for (const W1Attribute a : kW1Attributes) entries.emplace_back(to_string(a), attribute_ino(n.sensor, a));
  }
  std::vector<char> buffer(size);
  std::size_t used = 0;
  for (std::size_t i = static_cast<std::size_t>(off); i < entries.size(); ++i) {
    struct stat st {};
    st.st_ino = entries[i].second;
    st.st_mode = node_of(fs, entries[i].second).kind == Node::Kind::attribute ? S_IFREG : S_IFDIR;
    const std::size_t need = fuse_add_direntry(req, buffer.data() + used, size - used, entries[i].first.c_str(), &st,
                                               static_cast<off_t>(i + 1));
    if (need > size - used) break;
    used += need;
  }
  fuse_reply_buf(req, buffer.data(), used);
}

void on_open(fuse_req_t req, fuse_ino_t ino, fuse_file_info* fi) {
  W1Filesystem& fs = fs_of(req);
  const Node n = node_of(fs, ino);
  if (n.kind != Node::Kind::attribute) return (void)fuse_reply_err(req, EISDIR);
  if (!exists(fs, n)) return (void)fuse_reply_err(req, ENOENT);
  if ((fi->flags & O_ACCMODE) != O_RDONLY) return (void)fuse_reply_err(req, EACCES);
  fi->direct_io = 1;  // every read comes here: the file's size (a page) says nothing
  fi->keep_cache = 0;
  fi->fh = fs.open_handle({fs.bus().ids()[n.sensor], n.attribute, false, {}});
  fuse_reply_open(req, fi);
}

void on_read(fuse_req_t req, fuse_ino_t, size_t size, off_t off, fuse_file_info* fi) {
  W1Filesystem& fs = fs_of(req);
  W1Filesystem::Handle* h = fs.handle(fi->fh);
  if (h == nullptr) return (void)fuse_reply_err(req, EBADF);
  const auto slice = [&](const std::string& content) {
    const std::size_t from = std::min(static_cast<std::size_t>(off), content.size());
    return content.substr(from, std::min(size, content.size() - from));
  };
  if (h->read) {  // sysfs reads an attribute once per open file: later reads get the same text
    const std::string part = slice(h->content);
    return (void)fuse_reply_buf(req, part.data(), part.size());
  }
  // The first read of an open file runs the attribute (a conversion, for w1_slave and temperature).
  const double now_s = fs.clock().now_s();
  const W1Read r = fs.bus().read(h->id, h->attribute, now_s);
  const char* outcome = r.error != 0 ? "error" : r.content.empty() ? "empty" : "ok";
  fs.log().add(now_s, "w1", h->id, to_string(h->attribute), outcome);
  if (r.error != 0) return (void)fuse_reply_err(req, r.error);
  h->read = true;
  h->content = r.content;
  fs.reply_at(r.ready_s, req, slice(r.content));
}

void on_release(fuse_req_t req, fuse_ino_t, fuse_file_info* fi) {
  fs_of(req).close_handle(fi->fh);
  fuse_reply_err(req, 0);
}

const fuse_lowlevel_ops kFuseOps = [] {
  fuse_lowlevel_ops ops{};
  ops.lookup = on_lookup;
  ops.getattr = on_getattr;
  ops.readdir = on_readdir;
  ops.open = on_open;
  ops.read = on_read;
  ops.release = on_release;
  return ops;
}();

}  // namespace

W1Filesystem::W1Filesystem(std::string root, std::shared_ptr<W1Bus> bus, EventLog& log, hal::Clock& clock)
    : root_(std::move(root)), bus_(std::move(bus)), log_(log), clock_(clock) {
  std::error_code ec;
  if (!std::filesystem::is_directory(root_, ec)) {
    if (root_.rfind("/sys/", 0) == 0) {
      throw app::RuntimeFailure("w1_root '" + root_ + "' does not exist: under /sys it comes with the w1 core "
                                "(modprobe wire), or configure a w1_root outside /sys");
    }
    std::filesystem::create_directories(root_, ec);
    if (ec) throw app::RuntimeFailure("cannot create w1_root '" + root_ + "': " + ec.message());
  }
  char arg0[] = "gyrotc-emu", arg1[] = "-o", arg2[] = "allow_other,fsname=gyrotc-emu-w1,subtype=w1";
  char* argv[] = {arg0, arg1, arg2, nullptr};
  fuse_args args = FUSE_ARGS_INIT(3, argv);
  session_ = fuse_session_new(&args, &kFuseOps, sizeof kFuseOps, this);
  if (session_ == nullptr) throw app::RuntimeFailure("cannot create the FUSE session for '" + root_ + "'");
  if (fuse_session_mount(session_, root_.c_str()) != 0) {
    fuse_session_destroy(session_);
    session_ = nullptr;
    throw app::RuntimeFailure("cannot mount the emulated w1 tree on '" + root_ +
                              "' (FUSE: modprobe fuse; mounting needs root)");
  }
  mounted_ = true;
}

W1Filesystem::~W1Filesystem() {
  stop();
  if (session_ != nullptr) {
    if (mounted_) fuse_session_unmount(session_);
    fuse_session_destroy(session_);
  }
}

void W1Filesystem::start() {
  reply_thread_ = std::thread([this] { run_replies(); });
  thread_ = std::thread([this] { fuse_session_loop(session_); });
  // Conversions take 750 ms: nothing here needs the emulator's real-time priority.
  for (std::thread* t : {&reply_thread_, &thread_}) {
    sched_param normal{};
    (void)pthread_setschedparam(t->native_handle(), SCHED_OTHER, &normal);
  }
}

void W1Filesystem::stop() noexcept {
  if (thread_.joinable()) {
    fuse_session_exit(session_);
    wake_session_thread(thread_);
    thread_.join();
  }
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (reply_thread_.joinable()) reply_thread_.join();
  if (mounted_ && session_ != nullptr) {
    fuse_session_unmount(session_);
    mounted_ = false;
  }
}

std::uint64_t W1Filesystem::open_handle(Handle handle) {
  const std::lock_guard lock(mutex_);
  handles_[next_handle_] = std::move(handle);
  return next_handle_++;
}

W1Filesystem::Handle* W1Filesystem::handle(std::uint64_t fh) {
  const std::lock_guard lock(mutex_);
  const auto it = handles_.find(fh);
  return it == handles_.end() ? nullptr : &it->second;
}

void W1Filesystem::close_handle(std::uint64_t fh) {
  const std::lock_guard lock(mutex_);
  handles_.erase(fh);
}

void W1Filesystem::reply_at(double ready_s, fuse_req* req, std::string data) {
  {
    const std::lock_guard lock(mutex_);
    pending_.push({ready_s, req, std::move(data)});
  }
  wake_.notify_all();
}

void W1Filesystem::run_replies() {
  std::unique_lock lock(mutex_);
  for (;;) {
    if (stopping_) {
      // Whatever is still waiting is answered now: a stopped emulator leaves no reader hanging.
      while (!pending_.empty()) {
        fuse_reply_err(pending_.top().req, EIO);
        pending_.pop();
      }
      return;
    }
    if (pending_.empty()) {
      wake_.wait(lock);
      continue;
    }
    const double wait_s = pending_.top().ready_s - clock_.now_s();
    if (wait_s > 0.0) {
      wake_.wait_for(lock, std::chrono::duration<double>(std::min(wait_s, 0.05)));
      continue;
    }
    Pending p = pending_.top();
    pending_.pop();
    lock.unlock();
    fuse_reply_buf(p.req, p.data.data(), p.data.size());
    lock.lock();
  }
}

}  // namespace gyrotc::emu
