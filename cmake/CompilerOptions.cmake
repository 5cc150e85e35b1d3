# Warning, architecture and sanitizer flags shared by every target of the project.

add_library(basis_options INTERFACE)
target_compile_options(basis_options INTERFACE -Wall -Wextra -Wpedantic)
# No code reads errno after a maths function; without it sqrt and friends inline and vectorise.
target_compile_options(basis_options INTERFACE -fno-math-errno)
if(BASIS_NATIVE_ARCH)
  target_compile_options(basis_options INTERFACE -march=native)
endif()
# Without AVX-512 the convolution takes its AVX2 path, and without AVX2 its SSE4.1 path, as on
# CPUs that lack them: the sanitizer build takes the SSE4.1 path, so that the tests run it as
# well as the build machine's widest.
if(NOT BASIS_AVX512)
  target_compile_options(basis_options INTERFACE -mno-avx512f)
endif()
if(NOT BASIS_AVX2 AND NOT BASIS_AVX512)
  target_compile_options(basis_options INTERFACE -mno-avx2)
elseif(NOT BASIS_AVX2)
  message(WARNING "BASIS_AVX2=OFF takes effect only with BASIS_AVX512=OFF: this build keeps "
                  "AVX2 and AVX-512 where the machine has them")
endif()
if(BASIS_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "BASIS_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
  endif()
  # libFuzzer's coverage instrumentation goes on the readers' sources only (libbasis/ and
  # formats/ list them), so that the rest of the sanitizer build runs the tests at full speed.
  set(BASIS_FUZZ_INSTRUMENT -fsanitize=fuzzer-no-link)
endif()
if(BASIS_SANITIZE OR BASIS_FUZZ)
  target_compile_options(basis_options INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer
                                                 -fno-sanitize-recover=all)
  target_link_options(basis_options INTERFACE -fsanitize=address,undefined)
endif()
# In the sanitizer builds the tools' own sources (argument parsing, reports) are compiled
# without optimisation: they then compile in half the time, and the library they call, where
# the work is, keeps its optimisation (tools/ adds these options to its targets).
# Tests whose own code does no numeric work (THIN in cmake/Testing.cmake) are compiled with -O1
# in the other optimised builds: a third to half less compile time than -O3, and the same run
# time, which is spent in the tools and the library.
set(BASIS_THIN_TARGET_OPTIONS "")
set(BASIS_THIN_TEST_OPTIONS $<$<NOT:$<CONFIG:Debug>>:-O1>)
if(BASIS_SANITIZE OR BASIS_FUZZ)
  set(BASIS_THIN_TARGET_OPTIONS -O0)
  set(BASIS_THIN_TEST_OPTIONS -O0)
endif()
