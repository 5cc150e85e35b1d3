# basis_add_tests(NAME [THIN] [COST seconds] SOURCES... LINK targets... [ENVIRONMENT_APPEND VAR=text]):
# a GoogleTest executable whose tests ctest runs one by one (with text appended to that one
# variable as ctest's caller set it, so that what the caller chose still applies); the
# shared test helpers (tests/support) are on its include path and BASIS_SOURCE_DIR names the
# source tree (for data/ and ../shared/data). THIN: the tests' own code does no numeric work
# (they run the tools, or read and write files), so it is compiled with little optimisation
# (-O1 in optimised builds, none in the sanitizer builds: a third to half less compile time),
# while the library it calls keeps its optimisation. COST: about how long its slower tests take,
# set on each of its tests; ctest starts tests of higher COST first, so that long tests do not
# run alone at the end of a parallel run.
include(GoogleTest)

function(basis_add_tests name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "THIN" "COST;ENVIRONMENT_APPEND" "SOURCES;LINK")
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  target_compile_definitions(${name} PRIVATE BASIS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  if(arg_THIN)
    target_compile_options(${name} PRIVATE ${BASIS_THIN_TEST_OPTIONS})
  endif()
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "basis_add_tests(${name}): unexpected ${arg_UNPARSED_ARGUMENTS} "
                        "(ENVIRONMENT_APPEND takes one VAR=text)")
  endif()
  set(properties "")
  if(arg_ENVIRONMENT_APPEND)
    if(NOT arg_ENVIRONMENT_APPEND MATCHES "^([^=]+)=(.*)$")
      message(FATAL_ERROR "basis_add_tests(${name}): ENVIRONMENT_APPEND takes VAR=text")
    endif()
    list(APPEND properties ENVIRONMENT_MODIFICATION "${CMAKE_MATCH_1}=string_append:${CMAKE_MATCH_2}")
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
