# Warning and sanitizer flags, attached to targets through an interface library so that nothing
# leaks into projects that consume sspc.
add_library(sspc_compile_options INTERFACE)
target_compile_options(sspc_compile_options INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wconversion -Wsign-conversion -Wdouble-promotion -Wformat=2
  -Wimplicit-fallthrough)
# GCC 12 reports false -Wrestrict positives inside libstdc++'s std::string operator+ at -O3
# (GCC bug 105329); -Wnull-dereference likewise fires inside <streambuf>. Both stay off there.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  target_compile_options(sspc_compile_options INTERFACE -Wno-restrict)
endif()
if(SSPC_WERROR)
  target_compile_options(sspc_compile_options INTERFACE -Werror)
endif()
if(SSPC_SANITIZE)
  target_compile_options(sspc_compile_options INTERFACE
    -fsanitize=${SSPC_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  target_link_options(sspc_compile_options INTERFACE -fsanitize=${SSPC_SANITIZE})
  # SSPC_DCHECK (src/core/check.hpp) is on in sanitizer builds whatever the build type.
  target_compile_definitions(sspc_compile_options INTERFACE SSPC_ENABLE_DCHECK)
endif()
# The fuzz build instruments everything for libFuzzer's coverage feedback; the fuzzer executables
# add -fsanitize=fuzzer themselves (fuzz/CMakeLists.txt).
if(SSPC_BUILD_FUZZ)
  target_compile_options(sspc_compile_options INTERFACE -fsanitize=fuzzer-no-link)
endif()
