# Shared build helpers: one place for warnings, tests and executables.

function(depowder_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow
                         -Wnon-virtual-dtor -Wno-unused-parameter)
endfunction()

# depowder_library(name SOURCES ... [DEPS ...] [PRIVATE_DEPS ...])
function(depowder_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  depowder_warnings(${name})
endfunction()

# depowder_executable(name SOURCES ... DEPS ...): a process or tool, built into build/bin.
function(depowder_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  depowder_warnings(${name})
endfunction()

# depowder_test(name SOURCES ... DEPS ... [LABELS ...] [TIMEOUT s] [NETNS test] [NEEDS targets ...]):
# one GoogleTest executable. With NETNS it runs as test `test` inside a private network namespace
# (test/netns-run, DESIGN.md: udpm multicast never reaches a real interface), labelled netns;
# NEEDS: the executables it starts, built first.
function(depowder_test name)
  if(NOT BUILD_TESTING)
    return()
  endif()
  cmake_parse_arguments(ARG "" "TIMEOUT;NETNS" "SOURCES;DEPS;LABELS;NEEDS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/test/include)  # test helpers
  target_compile_definitions(${name} PRIVATE
    DEPOWDER_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    DEPOWDER_SHARED_DATA="${DEPOWDER_SHARED_DATA}"
    DEPOWDER_BIN_DIR="${CMAKE_RUNTIME_OUTPUT_DIRECTORY}")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  depowder_warnings(${name})
  if(ARG_NEEDS)
    add_dependencies(${name} ${ARG_NEEDS})
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(DEPOWDER_SANITIZE)  # the sanitized build runs about 10 times slower
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 3")
    target_compile_definitions(${name} PRIVATE DEPOWDER_SANITIZE=1)  # for a test with a time budget
  endif()
  if(ARG_NETNS)
    # udpm between processes: every test skips outside a private network namespace.
    target_sources(${name} PRIVATE ${PROJECT_SOURCE_DIR}/test/private_network_env.cpp)
    add_test(NAME ${ARG_NETNS} COMMAND ${PROJECT_SOURCE_DIR}/test/netns-run $<TARGET_FILE:${name}>)
    set_tests_properties(${ARG_NETNS} PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "netns;${ARG_LABELS}")
  else()
    add_test(NAME ${name} COMMAND ${name})
    set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_LABELS}")
  endif()
endfunction()
