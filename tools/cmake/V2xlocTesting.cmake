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
  set(skipped ${V2XLOC_FUZZ})  # the fuzz build compiles fuzz targets only
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

# v2xloc_fuzz_target(NAME name SOURCES ... LIBS ...)
# One libFuzzer target (LLVMFuzzerTestOneInput) with its seed corpus in <folder>/corpus/.
# - V2XLOC_FUZZ (clang): a libFuzzer binary; ctest runs it for V2XLOC_FUZZ_SECONDS (label fuzz),
#   growing a working corpus in the build tree from the committed seeds; crashers are written to
#   build/<preset>/fuzz_artifacts/<name>/ (add them to corpus/ as regression seeds).
# - any other build: the same code with a small driver that replays every corpus file once
#   (label unit), so the seeds and past crashers stay regression tests under g++, ASan and qemu.
set(V2XLOC_FUZZ_SECONDS 20 CACHE STRING "Seconds each fuzz target runs under ctest (V2XLOC_FUZZ)")
function(v2xloc_fuzz_target)
  cmake_parse_arguments(F "" "NAME" "SOURCES;LIBS" ${ARGN})
  set(corpus ${CMAKE_CURRENT_SOURCE_DIR}/corpus)
  if(V2XLOC_FUZZ)
    add_executable(${F_NAME} ${F_SOURCES})
    target_link_options(${F_NAME} PRIVATE -fsanitize=fuzzer)
  else()
    add_executable(${F_NAME} ${F_SOURCES} ${CMAKE_SOURCE_DIR}/tests/fuzz/replay_main.cpp)
  endif()
  target_link_libraries(${F_NAME} PRIVATE ${F_LIBS})
  set_target_properties(${F_NAME} PROPERTIES V2XLOC_TEST_EXECUTABLE ON)
  if(V2XLOC_FUZZ)
    set(work ${CMAKE_BINARY_DIR}/fuzz_corpus/${F_NAME})
    set(artifacts ${CMAKE_BINARY_DIR}/fuzz_artifacts/${F_NAME})
    file(MAKE_DIRECTORY ${work} ${artifacts})
    math(EXPR timeout "${V2XLOC_FUZZ_SECONDS} + 120")
    # -timeout: one input taking > 10 s is a hang; -rss_limit_mb: a lying size field must not
    # allocate gigabytes. The first corpus folder receives new inputs, the seeds stay untouched.
    add_test(NAME ${F_NAME} COMMAND ${F_NAME} -max_total_time=${V2XLOC_FUZZ_SECONDS} -timeout=10
             -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix=${artifacts}/ ${work} ${corpus})
    # libFuzzer refuses a missing corpus folder: recreate both folders before each run.
    add_test(NAME ${F_NAME}_folders COMMAND ${CMAKE_COMMAND} -E make_directory ${work} ${artifacts})
    set_tests_properties(${F_NAME}_folders PROPERTIES LABELS fuzz FIXTURES_SETUP ${F_NAME}_folders)
    set_tests_properties(${F_NAME} PROPERTIES LABELS fuzz TIMEOUT ${timeout} FIXTURES_REQUIRED ${F_NAME}_folders)
  else()
    add_test(NAME ${F_NAME}_corpus COMMAND ${F_NAME} ${corpus})
    set_tests_properties(${F_NAME}_corpus PROPERTIES LABELS unit TIMEOUT 300)
  endif()
endfunction()
