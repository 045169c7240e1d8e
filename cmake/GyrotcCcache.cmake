# Compiling through ccache, for the builds the scripts and presets make (the
# presets set GYROTC_CCACHE=AUTO; a plain configure, the DEB's and the Yocto
# recipe's, leaves it OFF and compiles exactly as without this file).
#
#   GYROTC_CCACHE  AUTO: through ccache when it is installed; ON: ccache is
#                  required; OFF: never. The environment variable of the same
#                  name, when set at configure time, overrides the cache entry
#                  (GYROTC_CCACHE=OFF ./scripts/check.sh).
#
# The cache is shared between checkouts: ccache's base_dir is the source tree,
# so the absolute paths of a compile line (-I, the source) become relative and
# a clean clone of the same commit in another folder hits what the working
# tree compiled. __FILE__ is relative already (-fmacro-prefix-map); the
# debug builds map the source tree in the debug info too, since ccache hashes
# the working directory it would otherwise record there.
set(GYROTC_CCACHE "OFF" CACHE STRING
    "Compile through ccache: AUTO (when installed), ON (required) or OFF; the environment variable GYROTC_CCACHE overrides it")
set_property(CACHE GYROTC_CCACHE PROPERTY STRINGS AUTO ON OFF)
set(GYROTC_CCACHE_MAX_SIZE "5G" CACHE STRING
    "The ccache size bound the build sets (ccache's max_size) when it compiles through ccache")

set(_gyrotc_ccache_mode "${GYROTC_CCACHE}")
if(DEFINED ENV{GYROTC_CCACHE})
  set(_gyrotc_ccache_mode "$ENV{GYROTC_CCACHE}")
endif()
string(TOUPPER "${_gyrotc_ccache_mode}" _gyrotc_ccache_mode)
if(NOT _gyrotc_ccache_mode MATCHES "^(AUTO|ON|OFF|)$")
  message(FATAL_ERROR "GYROTC_CCACHE is '${_gyrotc_ccache_mode}': expected AUTO, ON or OFF")
endif()

set(GYROTC_CCACHE_IN_USE OFF)
if(CMAKE_CXX_COMPILER_LAUNCHER)
  message(STATUS "ccache: not set up, CMAKE_CXX_COMPILER_LAUNCHER is given (${CMAKE_CXX_COMPILER_LAUNCHER})")
elseif(_gyrotc_ccache_mode MATCHES "^(AUTO|ON)$")
  find_program(GYROTC_CCACHE_PROGRAM ccache)
  if(GYROTC_CCACHE_PROGRAM)
    set(GYROTC_CCACHE_IN_USE ON)
    set(CMAKE_CXX_COMPILER_LAUNCHER
        "${CMAKE_COMMAND}" -E env
        "CCACHE_BASEDIR=${CMAKE_SOURCE_DIR}"
        "CCACHE_MAXSIZE=${GYROTC_CCACHE_MAX_SIZE}"
        "${GYROTC_CCACHE_PROGRAM}")
    # The working directory a debug build records, relative too (ccache then
    # hashes the mapped one: the same in every checkout).
    target_compile_options(gyrotc_options INTERFACE
      $<$<CONFIG:Debug,RelWithDebInfo>:-fdebug-prefix-map=${CMAKE_SOURCE_DIR}/=>)
    message(STATUS "ccache: compiling through ${GYROTC_CCACHE_PROGRAM} (base_dir ${CMAKE_SOURCE_DIR}, max_size ${GYROTC_CCACHE_MAX_SIZE})")
  elseif(_gyrotc_ccache_mode STREQUAL "ON")
    message(FATAL_ERROR "GYROTC_CCACHE is ON but ccache is not installed (apt-get install ccache, or GYROTC_CCACHE=AUTO)")
  else()
    message(STATUS "ccache: not installed, compiling without it")
  endif()
else()
  message(STATUS "ccache: off (GYROTC_CCACHE=OFF)")
endif()
