# basis_add_tests(NAME SOURCES... LINK targets... [ENVIRONMENT VAR=value...]): a GoogleTest
# executable whose tests ctest runs one by one (in that environment); the shared test helpers
# (tests/support) are on its include path and BASIS_SOURCE_DIR names the source tree (for data/
# and ../shared/data).
include(GoogleTest)

function(basis_add_tests name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "SOURCES;LINK;ENVIRONMENT")
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE BASIS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  if(arg_ENVIRONMENT)
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST PROPERTIES ENVIRONMENT "${arg_ENVIRONMENT}")
  else()
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST)
  endif()
endfunction()
