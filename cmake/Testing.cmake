# basis_add_tests(NAME [THIN] [COST seconds] SOURCES... LINK targets... [ENVIRONMENT VAR=value]):
# a GoogleTest executable whose tests ctest runs one by one (with that one variable set); the
# shared test helpers (tests/support) are on its include path and BASIS_SOURCE_DIR names the
# source tree (for data/ and ../shared/data). THIN: the tests' own code does no numeric work
# (they run the tools, or read and write files), so it is compiled with little optimisation
# (-O1 in optimised builds, none in the sanitizer builds: a third to half less compile time),
# while the library it calls keeps its optimisation. COST: about how long its slower tests take,
# set on each of its tests; ctest starts tests of higher COST first, so that long tests do not
# run alone at the end of a parallel run.
include(GoogleTest)

function(basis_add_tests name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "THIN" "COST" "SOURCES;LINK;ENVIRONMENT")
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE BASIS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  if(arg_THIN)
    target_compile_options(${name} PRIVATE ${BASIS_THIN_TEST_OPTIONS})
  endif()
  list(LENGTH arg_ENVIRONMENT variables)
  if(variables GREATER 1)
    message(FATAL_ERROR "basis_add_tests(${name}): ENVIRONMENT takes one VAR=value")
  endif()
  set(properties "")
  if(arg_ENVIRONMENT)
    list(APPEND properties ENVIRONMENT "${arg_ENVIRONMENT}")
  endif()
  if(arg_COST)
    list(APPEND properties COST ${arg_COST})
  endif()
  if(properties)
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST PROPERTIES ${properties})
  else()
    gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST)
  endif()
endfunction()
