# Compile options every gyrotc target gets: the warning level of the project,
# warnings as errors in CI, and the sanitizers of the debug preset.

add_library(gyrotc_options INTERFACE)
add_library(gyrotc::options ALIAS gyrotc_options)
target_compile_options(gyrotc_options INTERFACE
  -Wall -Wextra -Wpedantic -Wconversion -Wshadow
  $<$<BOOL:${GYROTC_WERROR}>:-Werror>
  # __FILE__ (assertions, Catch2's test locations) relative to the source tree:
  # no build machine path in what is installed (Yocto's buildpaths QA check).
  -fmacro-prefix-map=${CMAKE_SOURCE_DIR}/=)
# 64-bit file offsets and inode numbers on 32-bit targets (armhf): readdir()
# of a filesystem with 64-bit directory cookies (the w1 sysfs tree under
# qemu-arm, large ext4 directories) fails with EOVERFLOW without them.
target_compile_definitions(gyrotc_options INTERFACE _FILE_OFFSET_BITS=64)

if(GYROTC_SANITIZE)
  # -O1, as the AddressSanitizer docs advise: at -O0 Eigen's expression
  # templates ran the statistics tests 20-250x slower than Release, and the
  # slowest outran ctest's timeout on a loaded 2-core machine.
  # GCC 14 (trixie) at -O1 with the sanitizers' instrumentation reports
  # maybe-uninitialized inside libstdc++'s own std::regex and std::function:
  # false positives, which -Werror turned into a failed build. The aarch64
  # Release build keeps the warning, as an error.
  # A target with the property GYROTC_UBSAN_NUMERIC (the algorithms layer and
  # its tests: arithmetic on Eigen and std containers, no byte buffers read
  # through wider pointers) leaves out UBSan's alignment and null checks. They
  # instrument every Eigen coefficient access and took 60 % of the layer's
  # compile time with GCC 12 (a unit: 35 s with them, 14 s without; GCC 14's
  # whole sanitized build went from 505 to 492 s); a null dereference
  # there still faults, and AddressSanitizer reports it. hal, app and emu,
  # which cast bytes and pointers, keep them.
  target_compile_options(gyrotc_options INTERFACE
    -O1 -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined
    $<$<BOOL:$<TARGET_PROPERTY:GYROTC_UBSAN_NUMERIC>>:-fno-sanitize=alignment,null>
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized>)
  target_link_options(gyrotc_options INTERFACE -fsanitize=address,undefined)
endif()

# gyrotc_add_layer_library(<target> <folder> [EXCLUDE <regex>]): a static
# library of every .cpp under <folder>/src (but those matching <regex>) with
# public headers in <folder>/include.
function(gyrotc_add_layer_library target folder)
  cmake_parse_arguments(PARSE_ARGV 2 _arg "" "EXCLUDE" "")
  file(GLOB_RECURSE _sources CONFIGURE_DEPENDS "${folder}/src/*.cpp")
  if(_arg_EXCLUDE)
    list(FILTER _sources EXCLUDE REGEX "${_arg_EXCLUDE}")
  endif()
  add_library(${target} STATIC ${_sources})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${folder}/include>)
  target_link_libraries(${target} PRIVATE gyrotc::options)
endfunction()
