# basis_add_tests(NAME [THIN] SOURCES... LINK targets... [ENVIRONMENT VAR=value...]): a GoogleTest
# executable whose tests ctest runs one by one (in that environment); the shared test helpers
# (tests/support) are on its include path and BASIS_SOURCE_DIR names the source tree (for data/
# and ../shared/data). THIN: the tests' own code does no numeric work (they run the tools, or
# read and write files), so the sanitizer builds compile it as they compile the tools: without
# optimisation, in half the time, while the library it calls keeps its optimisation.
include(GoogleTest)

function(basis_add_tests name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "THIN" "" "SOURCES;LINK;ENVIRONMENT")
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE BASIS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  if(arg_THIN)
    target_compile_options(${name} PRIVATE ${BASIS_THIN_TARGET_OPTIONS})
  endif()
  if(arg_ENVIRONMENT)
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST PROPERTIES ENVIRONMENT "${arg_ENVIRONMENT}")
  else()
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST)
  endif()
endfunction()
