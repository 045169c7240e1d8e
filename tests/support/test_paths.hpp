#pragma once
// Where the tests find the seed's data, the example configurations and the
// gyrotc executable, at run time and without any build path compiled in, so
// the same test binaries run in the build tree, under qemu-user and from the
// ptest package on a target (which has only /usr/bin/gyrotc).
//
// The tree the test executables sit in (root) holds
//   tests/test_*     the test executables
//   share/gyrotc/    the seed's data (build tree: a link to the source data/)
//   config/          the example configurations (build tree: a link to deploy/config/)
//   app/gyrotc       the executable, in a build tree only
// root is the parent of the executable's folder; $GYROTC_TEST_ROOT overrides it.

#include <string>

namespace gyrotc::test {

std::string root();
std::string data_dir();                            // root/share/gyrotc
std::string data_file(const std::string& name);    // root/share/gyrotc/name
std::string config_file(const std::string& name);  // root/config/name
// $GYROTC_EXE, else root/app/gyrotc, else the gyrotc on $PATH (a target).
std::string gyrotc_exe();
// A folder of this test process's own under the temp folder, for the files
// a test writes (created on first use).
std::string scratch_dir();
// The text of config/gyrotc-sim.toml with its status file scratch_dir()/
// NAME.status.json: the shipped file's /tmp status path is shared by every
// daemon started on it, and a test's daemon must not overwrite another's (or
// a doc test's, which shows `gyrotc status` on the shipped file).
std::string sim_config_text(const std::string& name);
// That text, its calibration named by full path, written to
// scratch_dir()/NAME.toml; returns the path.
std::string sim_config_copy(const std::string& name);

}  // namespace gyrotc::test
