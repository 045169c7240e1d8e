#pragma once

#include <string>

namespace gyrotc::app {

// Where the seed's tables, the Fig. 26 chamber profile and the Table 2
// calibration are read from: $GYROTC_DATA_DIR when set, else the data folder
// of the prefix the executable sits in (/usr/bin/gyrotc reads /usr/share/gyrotc;
// the build tree mirrors that layout: build/<preset>/share/gyrotc links to the
// source tree's data/). No build path is compiled in, so an installed binary
// never reads a source tree and a build tree can move.
std::string data_dir();

// The folder the running executable is in (/proc/self/exe; under qemu-user
// the emulated program's).
std::string executable_dir();

}  // namespace gyrotc::app
