#pragma once
// Files that every test process of one executable may share. ctest runs each
// test case in a process of its own, so a result several cases read (a
// simulated record and its calibration: a minute under qemu-user) was made
// again by each; made here once, the others read it.

#include <functional>
#include <string>

namespace gyrotc::test {

// The folder NAME under a temp folder of this executable's build (keyed by
// its path, size and modification time: a rebuilt executable never reads an
// older build's files). The first caller runs make(dir) on a folder of its
// own and renames it into place, so a concurrent caller never sees it half
// made; a caller that loses the race keeps the winner's. If make throws,
// nothing is kept and the exception propagates.
std::string shared_result(const std::string& name, const std::function<void(const std::string& dir)>& make);

}  // namespace gyrotc::test
