# Settings shared by every dem_nerf library, whether built from the catkin package at the
# repository root or standalone (cmake -S packages/<name>): Release by default, C++17, and
# one helper to declare gtests so `make test` finds their XML results.
include_guard(GLOBAL)

if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  set(CMAKE_BUILD_TYPE Release CACHE STRING "Build type" FORCE)
endif()
set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_POSITION_INDEPENDENT_CODE ON)

# Where gtest XML results go; `make test` tallies every file under it.
if(NOT DEMNERF_TEST_RESULTS_DIR)
  set(DEMNERF_TEST_RESULTS_DIR "${CMAKE_BINARY_DIR}/test_results")
endif()

find_package(GTest QUIET)
enable_testing()
# OFF: no test executables (scripts/check_install.sh builds what an installed package needs only).
option(DEMNERF_BUILD_TESTS "build the gtests and the rostest checks" ON)

# demnerf_add_gtest(<target> SOURCES ... LIBRARIES ...): a gtest executable in
# <build>/bin/tests registered with ctest, writing <target>.xml into the results folder.
function(demnerf_add_gtest target)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT GTest_FOUND)
    message(STATUS "dem_nerf: GTest not found, ${target} is not built (run make setup)")
    return()
  endif()
  if(NOT DEMNERF_BUILD_TESTS)
    return()
  endif()
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_LIBRARIES} GTest::gtest GTest::gtest_main)
  set_target_properties(${target} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/tests")
  target_compile_definitions(${target} PRIVATE
    DEMNERF_SOURCE_DIR="${DEMNERF_ROOT_DIR}" DEMNERF_SHARED_DIR="${DEMNERF_ROOT_DIR}/../shared")
  add_test(NAME ${target} COMMAND ${target} --gtest_output=xml:${DEMNERF_TEST_RESULTS_DIR}/${target}.xml
           WORKING_DIRECTORY ${CMAKE_BINARY_DIR})
endfunction()
