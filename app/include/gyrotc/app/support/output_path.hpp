#pragma once

#include <string>

namespace gyrotc::app {

// Output files and folders are made ready before a command does its work, so
// that a long run never ends in "cannot write": a missing last folder is
// created (never a chain of them: a mistyped path is refused, not built), and
// a place that cannot be written is refused at once with a RuntimeFailure
// naming it and the option it came from.

// `path` will be written (created or replaced): its folder exists afterwards
// and is writable, and `path` itself is not a folder or a read-only file.
void prepare_output_file(const std::string& path, const std::string& option);
// `dir` will receive files: it exists afterwards and is a writable folder.
void prepare_output_dir(const std::string& dir, const std::string& option);

}  // namespace gyrotc::app
