#include "gyrotc/app/support/output_path.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "gyrotc/app/support/errors.hpp"

namespace gyrotc::app {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void refuse(const std::string& option, const std::string& path, const std::string& why) {
  throw RuntimeFailure(option + " " + path + ": " + why);
}

// Creates `dir` itself if it is missing, never a chain of parents: a
// mistyped path is refused rather than built.
void make_writable_dir(fs::path dir, const std::string& option, const std::string& shown) {
  // "out/" names the folder "out": its parent is ".", not "out".
  while (!dir.empty() && !dir.has_filename() && dir != dir.root_path()) dir = dir.parent_path();
  std::error_code ec;
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    if (fs::exists(dir, ec)) refuse(option, shown, "'" + dir.string() + "' is not a folder");
    const fs::path parent = dir.parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
      refuse(option, shown,
             "the folder '" + parent.string() + "' does not exist (only the last folder of an output path is created)");
    }
    fs::create_directory(dir, ec);
    if (ec) refuse(option, shown, "cannot create the folder '" + dir.string() + "': " + ec.message());
  }
  const fs::path probe = dir.empty() ? fs::path(".") : dir;
  if (::access(probe.c_str(), W_OK | X_OK) != 0) {
    refuse(option, shown, "the folder '" + probe.string() + "' is not writable: " + std::strerror(errno));
  }
}

}  // namespace

void prepare_output_file(const std::string& path, const std::string& option) {
  if (path.empty()) refuse(option, "''", "an empty file name");
  const fs::path p(path);
  std::error_code ec;
  if (fs::is_directory(p, ec)) refuse(option, path, "is a folder, not a file");
  make_writable_dir(p.parent_path(), option, path);
  if (fs::exists(p, ec) && ::access(p.c_str(), W_OK) != 0) {
    refuse(option, path, std::string("cannot be replaced: ") + std::strerror(errno));
  }
}

void prepare_output_dir(const std::string& dir, const std::string& option) {
  if (dir.empty()) refuse(option, "''", "an empty folder name");
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) refuse(option, dir, "exists and is not a folder");
  make_writable_dir(fs::path(dir), option, dir);
}

}  // namespace gyrotc::app
