SUMMARY = "Temperature compensation and control for MEMS gyroscopes"
DESCRIPTION = "gyrotc runs the temperature loop (DS18B20, AD5060 + OPA548 TEC stage) and \
the zero-bias compensation (ADS1251 in, AD5060 out) of a MEMS gyroscope as a \
real-time systemd service."
HOMEPAGE = "https://localhost/gyrotc"
SECTION = "utils"
LICENSE = "Apache-2.0"
LIC_FILES_CHKSUM = "file://LICENSE;md5=3b83ef96387f14655fc854ddc3c6bd57"

# By default the recipe builds the tree this layer lives in (deploy/yocto/meta-gyrotc
# inside the gyrotc repository). To build a fixed revision instead, in a bbappend
# (an empty EXTERNALSRC switches externalsrc off):
#   EXTERNALSRC = ""
#   SRC_URI = "git://<your server>/gyrotc.git;protocol=https;branch=main"
#   SRCREV = "<commit>"
#   S = "${WORKDIR}/git"   (scarthgap; walnascar: S = "${UNPACKDIR}/git")
EXTERNALSRC ?= "${@os.path.abspath(os.path.join(d.getVar('THISDIR'), '../../../../..'))}"
EXTERNALSRC_BUILD ?= "${WORKDIR}/build"

inherit externalsrc cmake pkgconfig systemd useradd ptest features_check

# The unit is Type=notify with a watchdog, and the user comes from useradd: a
# systemd image only.
REQUIRED_DISTRO_FEATURES = "systemd"

# The CMake project's third-party libraries (cmake/GyrotcDependencies.cmake), by recipe
# name; tests/deploy/check_yocto_layer.cmake keeps this list in step with the project.
# libgpiod: meta-oe's default (2.x) or a PREFERRED_VERSION_libgpiod = "1.6%" pin, both
# work (the CMake project picks the back-end of the version it finds).
DEPENDS = "libgpiod libeigen cli11 nlohmann-json tomlplusplus"

PACKAGECONFIG ??= "${@bb.utils.filter('DISTRO_FEATURES', 'systemd', d)} \
                   ${@bb.utils.contains('PTEST_ENABLED', '1', 'tests', '', d)}"
# sd_notify: READY=1 and the WATCHDOG=1 keep-alive of the Type=notify unit (gyrotc
# speaks the protocol itself: no libsystemd dependency).
PACKAGECONFIG[systemd] = "-DGYROTC_SYSTEMD_NOTIFY=ON,-DGYROTC_SYSTEMD_NOTIFY=OFF"
# Catch2 2 (scarthgap) or 3 (walnascar). Without an emulator the CMake project does not
# run the target's test binaries at build time (no test discovery); ptest runs them.
PACKAGECONFIG[tests] = "-DGYROTC_BUILD_TESTS=ON,-DGYROTC_BUILD_TESTS=OFF,catch2"

# gyrotc-emu, the board emulator (docs/EMULATOR.md): a package of its own and off by
# default, since a board that has its hardware never needs it. fuse3 (CUSE and FUSE)
# comes from meta-filesystems: PACKAGECONFIG:append:pn-gyrotc = " emu".
PACKAGECONFIG[emu] = "-DGYROTC_EMU=ON,-DGYROTC_EMU=OFF,fuse3"
PACKAGES =+ "${PN}-emu"
FILES:${PN}-emu = "${bindir}/gyrotc-emu ${datadir}/gyrotc-emu ${docdir}/gyrotc-emu"
RRECOMMENDS:${PN}-emu += "kernel-module-cuse kernel-module-gpio-sim kernel-module-wire"

# Google Benchmark is a workstation tool.
EXTRA_OECMAKE += " \
    -DGYROTC_BUILD_BENCH=OFF \
    -DGYROTC_WERROR=OFF \
    -DGYROTC_SYSTEMD_UNITDIR=${systemd_system_unitdir} \
    -DGYROTC_UDEV_RULESDIR=${nonarch_base_libdir}/udev/rules.d \
    -DGYROTC_SYSUSERSDIR=${nonarch_libdir}/sysusers.d \
    -DGYROTC_PTEST_DIR=${PTEST_PATH} \
"

USERADD_PACKAGES = "${PN}"
GROUPADD_PARAM:${PN} = "--system gyrotc"
USERADD_PARAM:${PN} = "--system --gid gyrotc --home-dir ${localstatedir}/lib/gyrotc \
                       --no-create-home --shell ${base_sbindir}/nologin gyrotc"

SYSTEMD_SERVICE:${PN} = "gyrotc.service"
SYSTEMD_AUTO_ENABLE:${PN} ?= "enable"

# The board's wiring and the unit's own calibration: kept across package upgrades.
CONFFILES:${PN} = " \
    ${sysconfdir}/gyrotc/gyrotc.toml \
    ${sysconfdir}/gyrotc/gyrotc-sim.toml \
    ${sysconfdir}/gyrotc/calibration.toml \
"
FILES:${PN} += " \
    ${systemd_system_unitdir}/gyrotc.service \
    ${nonarch_base_libdir}/udev/rules.d/60-gyrotc.rules \
    ${nonarch_libdir}/sysusers.d/gyrotc.conf \
    ${datadir}/gyrotc \
"

# The kernel drivers the board needs (modules on most kernels; where they are built in
# these packages do not exist, which a recommendation tolerates).
RRECOMMENDS:${PN} += "kernel-module-spidev kernel-module-w1-gpio kernel-module-w1-therm"

# The ptest tree comes from the CMake project itself (component "ptest": tests/test_*,
# share/gyrotc, config, run-ptest; the test binaries find everything relative to
# themselves and run /usr/bin/gyrotc), so nothing of ${S} or ${B} is on the target.
do_install_ptest() {
    DESTDIR=${D} cmake --install ${B} --component ptest
}
RDEPENDS:${PN}-ptest += "${PN}"
