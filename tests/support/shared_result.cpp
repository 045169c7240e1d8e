#include "shared_result.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace gyrotc::test {

namespace fs = std::filesystem;

namespace {

// gyrotc-test-shared-<executable>-<hash of its path>-<size>-<mtime ns>.
// Made the first time, after removing the folders of this executable's
// earlier builds (a developer's every rebuild would otherwise leave one).
fs::path build_folder() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("shared test results: cannot read /proc/self/exe: " + ec.message());
  struct stat st {};
  if (::stat(exe.c_str(), &st) != 0) throw std::runtime_error("shared test results: cannot stat " + exe.string());
  const long long mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
  return fs::temp_directory_path() /
         ("gyrotc-test-shared-" + exe.filename().string() + "-" +
          std::to_string(std::hash<std::string>{}(exe.string())) + "-" +
          std::to_string(static_cast<long long>(st.st_size)) + "-" + std::to_string(mtime_ns));
}

void remove_earlier_builds(const fs::path& folder) {
  const std::string name = folder.filename().string();
  const std::string prefix = name.substr(0, name.rfind('-', name.rfind('-') - 1) + 1);
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(folder.parent_path(), ec)) {
    const std::string other = e.path().filename().string();
    if (other != name && other.rfind(prefix, 0) == 0) fs::remove_all(e.path(), ec);
  }
}

}  // namespace

std::string shared_result(const std::string& name, const std::function<void(const std::string& dir)>& make) {
  const fs::path base = build_folder();
  const fs::path done = base / name;
  if (fs::is_directory(done)) return done.string();
  if (!fs::exists(base)) remove_earlier_builds(base);
  fs::create_directories(base);
  const fs::path work = base / (name + ".making-" + std::to_string(::getpid()));
  fs::remove_all(work);
  fs::create_directories(work);
  try {
    make(work.string());
  } catch (...) {
    std::error_code ec;
    fs::remove_all(work, ec);
    throw;
  }
  // rename(2) of a folder onto a non-empty one fails (ENOTEMPTY or EEXIST):
  // another process finished first, and its folder is as good as ours.
  if (std::rename(work.c_str(), done.c_str()) != 0) {
    const int err = errno;
    std::error_code ec;
    fs::remove_all(work, ec);
    if (!(err == ENOTEMPTY || err == EEXIST) || !fs::is_directory(done)) {
      throw std::system_error(err, std::generic_category(), "shared test results: rename to " + done.string());
    }
  }
  return done.string();
}

}  // namespace gyrotc::test
