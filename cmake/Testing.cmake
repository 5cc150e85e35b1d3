# basis_add_tests(NAME SOURCES... LINK targets...): a GoogleTest executable whose tests ctest
# runs one by one; the shared test helpers (tests/support) are on its include path and
# BASIS_SOURCE_DIR names the source tree (for data/ and ../shared/data).
include(GoogleTest)

function(basis_add_tests name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "SOURCES;LINK")
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE BASIS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST)
endfunction()
