# GoogleTest is built from Debian's sources (/usr/src/googletest) so cross builds get a
# target-architecture copy too; ctest runs cross-built tests through CMAKE_CROSSCOMPILING_EMULATOR.
if(NOT TARGET gtest AND V2XLOC_BUILD_TESTS)
  set(INSTALL_GTEST OFF CACHE BOOL "" FORCE)
  set(BUILD_GMOCK ON CACHE BOOL "" FORCE)
  add_subdirectory(/usr/src/googletest ${CMAKE_BINARY_DIR}/_googletest EXCLUDE_FROM_ALL SYSTEM)
endif()
include(GoogleTest)

# Test labels a preset never runs (e.g. aarch64-linux: slow;bench;e2e;host-only, the labels its
# test preset excludes): such test executables are not built by `all` and not registered with
# ctest, so a cross build does not compile tests it cannot run. Keep in step with the test preset.
set(V2XLOC_SKIP_TEST_LABELS "" CACHE STRING "Test labels whose executables this build skips")

# v2xloc_gtest(NAME name SOURCES ... LIBS ... [LABELS ...] [TIMEOUT s] [NO_MAIN])
# One gtest executable; each TEST becomes its own ctest entry (discovered at test time,
# through the emulator when cross-compiling).
function(v2xloc_gtest)
  cmake_parse_arguments(T "NO_MAIN" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  set(skipped OFF)
  foreach(label ${T_LABELS})
    if(label IN_LIST V2XLOC_SKIP_TEST_LABELS)
      set(skipped ON)
    endif()
  endforeach()
  add_executable(${T_NAME} ${T_SOURCES})
  set_target_properties(${T_NAME} PROPERTIES V2XLOC_TEST_EXECUTABLE ON)
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} gtest gmock)
  if(NOT T_NO_MAIN)
    target_link_libraries(${T_NAME} PRIVATE gtest_main)
  endif()
  target_compile_definitions(${T_NAME} PRIVATE
    V2XLOC_SHARED_DATA_DIR="${V2XLOC_SHARED_DATA_DIR}"
    V2XLOC_SOURCE_DIR="${CMAKE_SOURCE_DIR}"
    V2XLOC_BINARY_DIR="${CMAKE_BINARY_DIR}")
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 600)
  endif()
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  if(skipped)
    # The target stays (others may add_dependencies on it), buildable by name only.
    set_target_properties(${T_NAME} PROPERTIES EXCLUDE_FROM_ALL ON V2XLOC_TEST_EXECUTABLE OFF)
    return()
  endif()
  gtest_discover_tests(${T_NAME} DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 120
    PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
endfunction()

# V2XLOC_TESTS_ONLY: `all` builds only the registered test executables and what they link; every
# other target (simulator and tool executables, their libraries) stays buildable by name. For
# cross presets whose only job is running the unit tests under an emulator.
function(v2xloc_exclude_non_test_targets dir)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(t ${targets})
    get_target_property(type ${t} TYPE)
    get_target_property(is_test ${t} V2XLOC_TEST_EXECUTABLE)
    if(NOT type STREQUAL "INTERFACE_LIBRARY" AND NOT is_test)
      set_target_properties(${t} PROPERTIES EXCLUDE_FROM_ALL ON)
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub ${subdirs})
    v2xloc_exclude_non_test_targets(${sub})
  endforeach()
endfunction()
