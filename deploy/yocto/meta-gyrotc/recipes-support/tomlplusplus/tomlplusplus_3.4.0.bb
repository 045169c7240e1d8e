# toml++ for releases whose meta-oe lacks it (scarthgap, styhead). meta-oe carries a
# tomlplusplus recipe (also 3.4.0) from walnascar on: this one steps aside for it.
DEFAULT_PREFERENCE = "-1"
SUMMARY = "Header-only TOML config file parser and serializer for C++17"
HOMEPAGE = "https://marzer.github.io/tomlplusplus/"
SECTION = "libs"
LICENSE = "MIT"
LIC_FILES_CHKSUM = "file://LICENSE;md5=90960f22c10049c117d56ed2ee5ee167"

SRC_URI = "https://github.com/marzer/tomlplusplus/archive/refs/tags/v${PV}.tar.gz;downloadfilename=${BP}.tar.gz"
SRC_URI[sha256sum] = "8517f65938a4faae9ccf8ebb36631a38c1cadfb5efa85d9a72e15b9e97d25155"

inherit cmake

# Header-only: everything is in the -dev package (headers, CMake package config).
ALLOW_EMPTY:${PN} = "1"
BBCLASSEXTEND = "native nativesdk"
