# Install rules and the DEB package: the documented tree (docs/GUIDE.md, "Deploy").
# With CMAKE_INSTALL_PREFIX=/usr (Debian, Yocto):
#   /usr/bin/gyrotc
#   /etc/gyrotc/gyrotc.toml            deploy/config/gyrotc-linux.toml (the board)
#   /etc/gyrotc/gyrotc-sim.toml        deploy/config/gyrotc-sim.toml (no hardware)
#   /etc/gyrotc/calibration.toml       data/calibration_table2.toml (seed calibration;
#                                      replace with the unit's own, see docs/GUIDE.md)
#   /usr/lib/systemd/system/gyrotc.service, /usr/lib/sysusers.d/gyrotc.conf
#   /usr/lib/udev/rules.d/60-gyrotc.rules
#   /usr/share/gyrotc/                 the seed's tables and chamber profile (data/)
#   /usr/share/doc/gyrotc/             README.md, docs/*.md, LICENSE, copyright (Debian's format)
# The configuration is per unit (wiring, calibration), so it lives in /etc as conffiles;
# the binary itself comes from app/CMakeLists.txt.

set(GYROTC_SYSTEMD_UNITDIR "lib/systemd/system" CACHE STRING
  "Where gyrotc.service goes (relative to the prefix, or absolute: Yocto passes \${systemd_system_unitdir})")
set(GYROTC_UDEV_RULESDIR "lib/udev/rules.d" CACHE STRING
  "Where 60-gyrotc.rules goes (relative to the prefix, or absolute)")
set(GYROTC_SYSUSERSDIR "lib/sysusers.d" CACHE STRING
  "Where the systemd-sysusers entry for the gyrotc user goes (relative to the prefix, or absolute)")

set(_gyrotc_confdir "${CMAKE_INSTALL_FULL_SYSCONFDIR}/gyrotc")
set(_gyrotc_deploy "${CMAKE_CURRENT_SOURCE_DIR}/deploy")

install(FILES ${_gyrotc_deploy}/config/gyrotc-linux.toml
  DESTINATION ${_gyrotc_confdir} RENAME gyrotc.toml)
install(FILES ${_gyrotc_deploy}/config/gyrotc-sim.toml DESTINATION ${_gyrotc_confdir})
install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/data/calibration_table2.toml
  DESTINATION ${_gyrotc_confdir} RENAME calibration.toml)

# The unit names /usr/bin and /etc/gyrotc; other prefixes get their own paths.
file(READ ${_gyrotc_deploy}/systemd/gyrotc.service _gyrotc_unit)
string(REPLACE "/usr/bin/gyrotc" "${CMAKE_INSTALL_FULL_BINDIR}/gyrotc" _gyrotc_unit "${_gyrotc_unit}")
string(REPLACE "/etc/gyrotc/" "${_gyrotc_confdir}/" _gyrotc_unit "${_gyrotc_unit}")
string(REPLACE "/usr/share/doc/gyrotc/" "${CMAKE_INSTALL_FULL_DOCDIR}/" _gyrotc_unit "${_gyrotc_unit}")
file(CONFIGURE OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/deploy/gyrotc.service CONTENT "${_gyrotc_unit}" @ONLY)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${_gyrotc_deploy}/systemd/gyrotc.service)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/deploy/gyrotc.service DESTINATION ${GYROTC_SYSTEMD_UNITDIR})
if(NOT GYROTC_SYSTEMD_NOTIFY)
  message(STATUS "gyrotc: GYROTC_SYSTEMD_NOTIFY=OFF: the installed gyrotc.service (Type=notify, "
                 "WatchdogSec) will never see READY=1")
endif()
install(FILES ${_gyrotc_deploy}/systemd/gyrotc.sysusers
  DESTINATION ${GYROTC_SYSUSERSDIR} RENAME gyrotc.conf)
install(FILES ${_gyrotc_deploy}/udev/60-gyrotc.rules DESTINATION ${GYROTC_UDEV_RULESDIR})

file(GLOB _gyrotc_data CONFIGURE_DEPENDS
  ${CMAKE_CURRENT_SOURCE_DIR}/data/*.csv ${CMAKE_CURRENT_SOURCE_DIR}/data/*.toml
  ${CMAKE_CURRENT_SOURCE_DIR}/data/README.md)
install(FILES ${_gyrotc_data} DESTINATION ${CMAKE_INSTALL_DATADIR}/gyrotc)
file(GLOB _gyrotc_docs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/docs/*.md)
install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/README.md ${_gyrotc_docs} ${CMAKE_CURRENT_SOURCE_DIR}/LICENSE
  ${_gyrotc_deploy}/debian/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})

# The board emulator's package (docs/EMULATOR.md): its examples and documents.
if(GYROTC_BUILD_EMU)
  install(FILES ${_gyrotc_deploy}/emu/gyrotc-emu.toml ${_gyrotc_deploy}/emu/plant-fast.toml
          DESTINATION ${CMAKE_INSTALL_DATADIR}/gyrotc-emu COMPONENT emu)
  install(FILES ${CMAKE_CURRENT_SOURCE_DIR}/docs/EMULATOR.md ${CMAKE_CURRENT_SOURCE_DIR}/LICENSE
          ${_gyrotc_deploy}/debian/copyright DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/gyrotc-emu COMPONENT emu)
endif()

# --- DEB (cpack -G DEB from a build configured with -DCMAKE_INSTALL_PREFIX=/usr) ---
# Two packages: gyrotc (the daemon and everything above) and, when it is
# built, gyrotc-emu (the board emulator: never needed on a board that has its
# hardware). The ptest component stays out of both.
set(CPACK_GENERATOR DEB)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL Unspecified)
if(GYROTC_BUILD_EMU)
  list(APPEND CPACK_COMPONENTS_ALL emu)
endif()
set(CPACK_DEBIAN_UNSPECIFIED_PACKAGE_NAME gyrotc)
set(CPACK_DEBIAN_EMU_PACKAGE_NAME gyrotc-emu)
set(CPACK_DEBIAN_EMU_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_EMU_PACKAGE_SUGGESTS gyrotc)
string(CONCAT CPACK_DEBIAN_EMU_DESCRIPTION
  "gyrotc board emulator: the simulated board behind CUSE, gpio-sim and w1\n"
  "gyrotc-emu presents the simulated gyrotc board (ADS1251, AD5060, OPA548, DS18B20\n"
  "and the thermal plant) at the kernel's own interfaces, so that the unmodified\n"
  "daemon with hal = linux runs against it: bring-up of a board configuration\n"
  "before the hardware exists, and hardware-in-the-loop tests.")
set(CPACK_PACKAGE_NAME gyrotc)
set(CPACK_PACKAGE_VENDOR "gyrotc")
set(CPACK_PACKAGE_CONTACT "gyrotc maintainers <gyrotc@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_PACKAGING_INSTALL_PREFIX "${CMAKE_INSTALL_PREFIX}")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # libgpiod2, libstdc++6 ... from the binary
set(CPACK_DEBIAN_UNSPECIFIED_PACKAGE_DEPENDS "adduser")
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://localhost/gyrotc")
if(CMAKE_CROSSCOMPILING AND CMAKE_LIBRARY_ARCHITECTURE MATCHES "aarch64")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
elseif(CMAKE_CROSSCOMPILING AND CMAKE_LIBRARY_ARCHITECTURE MATCHES "arm-linux-gnueabihf")
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE armhf)
endif()
# Keep a site's edited configuration and calibration across upgrades.
file(CONFIGURE OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/deploy/debian/conffiles CONTENT
  "${_gyrotc_confdir}/gyrotc.toml\n${_gyrotc_confdir}/gyrotc-sim.toml\n${_gyrotc_confdir}/calibration.toml\n")
# preinst creates the user and group from the sysusers entries before the udev rule
# naming the group is unpacked (why: deploy/debian/preinst.in).
file(STRINGS ${_gyrotc_deploy}/systemd/gyrotc.sysusers _gyrotc_sysusers_entries REGEX "^[^#]")
list(JOIN _gyrotc_sysusers_entries "\n" GYROTC_SYSUSERS_ENTRIES)
cmake_path(ABSOLUTE_PATH GYROTC_SYSUSERSDIR BASE_DIRECTORY ${CMAKE_INSTALL_PREFIX}
  OUTPUT_VARIABLE GYROTC_SYSUSERS_FILE)
string(APPEND GYROTC_SYSUSERS_FILE "/gyrotc.conf")
configure_file(${_gyrotc_deploy}/debian/preinst.in ${CMAKE_CURRENT_BINARY_DIR}/deploy/debian/preinst
  @ONLY FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE
  WORLD_READ WORLD_EXECUTE)
set(CPACK_DEBIAN_UNSPECIFIED_PACKAGE_CONTROL_EXTRA
  ${CMAKE_CURRENT_BINARY_DIR}/deploy/debian/conffiles
  ${CMAKE_CURRENT_BINARY_DIR}/deploy/debian/preinst ${_gyrotc_deploy}/debian/postinst ${_gyrotc_deploy}/debian/prerm ${_gyrotc_deploy}/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
