#pragma once

#include <string>

namespace gyrotc::app {

// Where the seed's tables, the Fig. 26 chamber profile and the Table 2
// calibration are read from: $GYROTC_DATA_DIR when set, else the source
// tree's data/ when it exists (build-tree runs and tests), else the installed
// ${datadir}/gyrotc (a board or a DEB install, where the source tree is absent).
std::string data_dir();

}  // namespace gyrotc::app
