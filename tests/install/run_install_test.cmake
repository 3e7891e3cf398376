# Install-and-consume check, run by ctest as `cmake -P`:
#   1. (cross cases) configure this source tree with the toolchain file into WORK/build, build only
#      the installed libraries, or (host) reuse the already-built tree BUILD_DIR;
#   2. `cmake --install --component core` into WORK/prefix;
#   3. configure + build tests/install/consumer against that prefix with find_package(v2xloc);
#   4. run the consumer (host directly, aarch64 under EMULATOR), or for bare-metal only link it.
# Inputs (-D): SOURCE_DIR, WORK, CASE (host|aarch64|cortex-r52), BUILD_DIR (host case),
# TOOLCHAIN, PROFILE (DEFAULT|EMBEDDED), EMULATOR (;-list), GENERATOR, BUILD_TYPE, CXX_FLAGS.
cmake_minimum_required(VERSION 3.25)

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${CASE}: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK}/prefix ${WORK}/consumer)
set(toolchain_args "")
if(TOOLCHAIN)
  set(toolchain_args -DCMAKE_TOOLCHAIN_FILE=${TOOLCHAIN})
endif()

if(CASE STREQUAL "host")
  set(build ${BUILD_DIR})
else()
  # Same build type and flags as the matching preset, so ccache can reuse its objects.
  set(build ${WORK}/build)
  set(options -DV2XLOC_BUILD_TESTS=OFF -DV2XLOC_BUILD_BENCHMARKS=OFF)
  set(targets v2xloc_algo v2xloc_protocol)
  if(CASE STREQUAL "cortex-r52")
    list(APPEND options -DV2XLOC_BAREMETAL=ON)
  else()
    list(APPEND targets v2xloc_hal)
  endif()
  if(NOT PROFILE STREQUAL "DEFAULT")
    list(APPEND options -DV2XLOC_PROFILE=${PROFILE})
  endif()
  if(CXX_FLAGS)
    list(APPEND options "-DCMAKE_CXX_FLAGS_${BUILD_TYPE_UPPER}=${CXX_FLAGS}")
  endif()
  run_step("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${build} -G ${GENERATOR}
           ${toolchain_args} -DCMAKE_BUILD_TYPE=${BUILD_TYPE} ${options})
  run_step("build" ${CMAKE_COMMAND} --build ${build} --target ${targets})
endif()

run_step("install" ${CMAKE_COMMAND} --install ${build} --component core --prefix ${WORK}/prefix)
foreach(f lib/cmake/v2xloc/v2xloc-config.cmake lib/cmake/v2xloc/v2xloc-config-version.cmake
          include/v2xloc/algo/core/config.hpp include/v2xloc/firmware/protocol/crc32.hpp)
  if(NOT EXISTS ${WORK}/prefix/${f})
    message(FATAL_ERROR "${CASE}: the install has no ${f}")
  endif()
endforeach()
file(READ ${WORK}/prefix/lib/cmake/v2xloc/v2xloc-config.cmake config)
if(NOT config MATCHES "set\\(V2XLOC_PROFILE \"${PROFILE}\"\\)")
  message(FATAL_ERROR "${CASE}: v2xloc-config.cmake does not record profile ${PROFILE}")
endif()

run_step("consumer configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer
         -B ${WORK}/consumer -G ${GENERATOR} ${toolchain_args} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
         -DCMAKE_PREFIX_PATH=${WORK}/prefix -DEXPECTED_PROFILE=${PROFILE})
run_step("consumer build" ${CMAKE_COMMAND} --build ${WORK}/consumer)
if(CASE STREQUAL "cortex-r52")
  if(NOT EXISTS ${WORK}/consumer/v2xloc_consumer)
    message(FATAL_ERROR "${CASE}: the consumer did not link")
  endif()
  message(STATUS "${CASE}: consumer linked against the installed package (not run: bare metal)")
  return()
endif()
run_step("consumer run" ${EMULATOR} ${WORK}/consumer/v2xloc_consumer)
if(NOT step_output MATCHES "v2xloc consumer: ok \\(profile ${PROFILE}\\)")
  message(FATAL_ERROR "${CASE}: unexpected consumer output: ${step_output}")
endif()
message(STATUS "${CASE}: ${step_output}")
