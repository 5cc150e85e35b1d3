# Warning, architecture and sanitizer flags shared by every target of the project.

add_library(basis_options INTERFACE)
target_compile_options(basis_options INTERFACE -Wall -Wextra -Wpedantic)
if(BASIS_NATIVE_ARCH)
  target_compile_options(basis_options INTERFACE -march=native)
endif()
if(BASIS_SANITIZE)
  target_compile_options(basis_options INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer
                                                 -fno-sanitize-recover=all)
  target_link_options(basis_options INTERFACE -fsanitize=address,undefined)
endif()
if(BASIS_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "BASIS_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  target_compile_options(basis_options INTERFACE -fsanitize=fuzzer-no-link,address,undefined
                                                 -fno-omit-frame-pointer -fno-sanitize-recover=all)
  target_link_options(basis_options INTERFACE -fsanitize=address,undefined)
endif()
