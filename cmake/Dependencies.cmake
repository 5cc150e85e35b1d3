# Third-party libraries, all from Debian bookworm packages, found through their CMake packages.

find_package(Eigen3 3.4 REQUIRED CONFIG)
find_package(TBB REQUIRED CONFIG)
find_package(CLI11 REQUIRED CONFIG)
find_package(OpenEXR REQUIRED CONFIG)
find_package(OpenImageIO REQUIRED CONFIG)
find_package(embree 3 REQUIRED CONFIG)
find_package(FlatBuffers REQUIRED CONFIG)
find_package(nlohmann_json 3 REQUIRED CONFIG)
find_package(tinyobjloader REQUIRED CONFIG)
find_package(nanoflann REQUIRED CONFIG)
# xxHash (checksums of .qt and shard files) has no CMake package in Debian: its pkg-config file.
# 0.8.0 on: XXH3-128's output is fixed from that release, and .qt files store it.
find_package(PkgConfig REQUIRED)
pkg_check_modules(xxhash REQUIRED IMPORTED_TARGET libxxhash>=0.8.0)
if(BASIS_BUILD_TESTS)
  find_package(GTest REQUIRED CONFIG)
  find_package(benchmark REQUIRED CONFIG)
endif()

# Debian's OpenImageIO exports /usr/include/opencv4, which is absent unless OpenCV's headers are
# installed; CMake refuses to generate with a missing interface include directory.
foreach(property INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
  get_target_property(dirs OpenImageIO::OpenImageIO ${property})
  if(dirs)
    list(FILTER dirs EXCLUDE REGEX "opencv4")
    set_target_properties(OpenImageIO::OpenImageIO PROPERTIES ${property} "${dirs}")
  endif()
endforeach()
