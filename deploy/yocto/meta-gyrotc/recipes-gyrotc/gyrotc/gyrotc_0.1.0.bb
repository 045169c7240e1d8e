SUMMARY = "Temperature compensation and control for MEMS gyroscopes"
DESCRIPTION = "gyrotc runs the temperature loop (DS18B20, AD5060 + OPA548 TEC stage) and \
the zero-bias compensation (ADS1251 in, AD5060 out) of a MEMS gyroscope as a \
real-time systemd service."
SECTION = "utils"
# The project has no licence file yet: change this together with LIC_FILES_CHKSUM when it does.
LICENSE = "CLOSED"

# By default the recipe builds the tree this layer lives in (deploy/yocto/meta-gyrotc
# inside the gyrotc repository). To build a fixed revision instead, in a bbappend:
#   EXTERNALSRC = ""
#   SRC_URI = "git://<your server>/gyrotc.git;protocol=https;branch=main file://run-ptest"
#   SRCREV = "<commit>"
#   S = "${WORKDIR}/git"
EXTERNALSRC ?= "${@os.path.abspath(os.path.join(d.getVar('THISDIR'), '../../../../..'))}"
EXTERNALSRC_BUILD ?= "${WORKDIR}/build"
SRC_URI = "file://run-ptest"

inherit externalsrc cmake pkgconfig systemd useradd ptest

# The CMake project's third-party libraries (cmake/GyrotcDependencies.cmake), by recipe
# name; tests/deploy/check_yocto_layer.cmake keeps this list in step with the project.
# libgpiod must be 1.6.x: PREFERRED_VERSION_libgpiod = "1.6%" (see the layer README).
DEPENDS = "libgpiod libeigen cli11 nlohmann-json tomlplusplus"

PACKAGECONFIG ??= "${@bb.utils.filter('DISTRO_FEATURES', 'systemd', d)} \
                   ${@bb.utils.contains('PTEST_ENABLED', '1', 'tests', '', d)}"
# sd_notify: READY=1 and the WATCHDOG=1 keep-alive of the Type=notify unit (gyrotc
# speaks the protocol itself: no libsystemd dependency).
PACKAGECONFIG[systemd] = "-DGYROTC_SYSTEMD_NOTIFY=ON,-DGYROTC_SYSTEMD_NOTIFY=OFF"
PACKAGECONFIG[tests] = "-DGYROTC_BUILD_TESTS=ON,-DGYROTC_BUILD_TESTS=OFF,catch2"

# Google Benchmark is a workstation tool. Catch2 tests are listed when ctest runs,
# not by running the target binaries at build time.
EXTRA_OECMAKE += " \
    -DGYROTC_BUILD_BENCH=OFF \
    -DGYROTC_WERROR=OFF \
    -DGYROTC_SYSTEMD_UNITDIR=${systemd_system_unitdir} \
    -DGYROTC_UDEV_RULESDIR=${nonarch_base_libdir}/udev/rules.d \
    -DGYROTC_SYSUSERSDIR=${nonarch_libdir}/sysusers.d \
    -DCMAKE_CATCH_DISCOVER_TESTS_DISCOVERY_MODE=PRE_TEST \
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

# The test executables have the source tree's path compiled in (seed data, example
# configurations): the ptest package carries data/ and deploy/config/, and run-ptest
# links that path to them on the target.
do_install_ptest() {
    install -d ${D}${PTEST_PATH}/tests ${D}${PTEST_PATH}/source/deploy
    for t in ${B}/tests/test_*; do
        if [ -f "$t" ] && [ -x "$t" ]; then
            install -m 0755 "$t" ${D}${PTEST_PATH}/tests/
        fi
    done
    cp -R --no-preserve=ownership ${S}/data ${D}${PTEST_PATH}/source/
    cp -R --no-preserve=ownership ${S}/deploy/config ${D}${PTEST_PATH}/source/deploy/
    sed -i -e 's#@GYROTC_BUILD_SOURCE_DIR@#${S}#' -e 's#@GYROTC_BUILD_BINARY_DIR@#${B}#' \
        ${D}${PTEST_PATH}/run-ptest
}
RDEPENDS:${PN}-ptest += "${PN}"
