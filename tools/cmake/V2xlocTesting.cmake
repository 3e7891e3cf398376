# GoogleTest is built from Debian's sources (/usr/src/googletest) so cross builds get a
# target-architecture copy too; ctest runs cross-built tests through CMAKE_CROSSCOMPILING_EMULATOR.
if(NOT TARGET gtest AND V2XLOC_BUILD_TESTS)
  set(INSTALL_GTEST OFF CACHE BOOL "" FORCE)
  set(BUILD_GMOCK ON CACHE BOOL "" FORCE)
  add_subdirectory(/usr/src/googletest ${CMAKE_BINARY_DIR}/_googletest EXCLUDE_FROM_ALL SYSTEM)
endif()
include(GoogleTest)

# v2xloc_gtest(NAME name SOURCES ... LIBS ... [LABELS ...] [TIMEOUT s] [NO_MAIN])
# One gtest executable; each TEST becomes its own ctest entry (discovered at test time,
# through the emulator when cross-compiling).
function(v2xloc_gtest)
  cmake_parse_arguments(T "NO_MAIN" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${T_NAME} ${T_SOURCES})
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
  gtest_discover_tests(${T_NAME} DISCOVERY_MODE PRE_TEST DISCOVERY_TIMEOUT 120
    PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
endfunction()
