# `cmake --install` (component "core"): the allocation-free core and its wire-format codecs as a
# CMake package, v2xloc::algo, v2xloc::protocol and (Linux) v2xloc::hal, found with
# find_package(v2xloc). The targets add themselves to the export set in their own CMakeLists.txt
# (install(TARGETS ... EXPORT v2xloc-targets)); this file writes the set and the config files.
# Layout under the prefix:
#   include/v2xloc/algo/...             #include "v2xloc/algo/..."
#   include/v2xloc/hal/*.hpp            #include "hal/..."                (include/v2xloc on the path)
#   include/v2xloc/firmware/protocol/   #include "firmware/protocol/..."  (include/v2xloc on the path)
#   lib/libv2xloc_*.a
#   lib/cmake/v2xloc/v2xloc-{config,config-version,targets*}.cmake
include(CMakePackageConfigHelpers)
include(GNUInstallDirs)

set(V2XLOC_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/v2xloc)
if(V2XLOC_PROFILE)
  set(V2XLOC_INSTALL_PROFILE ${V2XLOC_PROFILE})
else()
  set(V2XLOC_INSTALL_PROFILE DEFAULT)
endif()
set(V2XLOC_INSTALL_COMPONENTS algo protocol)
if(TARGET v2xloc_hal)
  list(APPEND V2XLOC_INSTALL_COMPONENTS hal)
endif()

install(EXPORT v2xloc-targets NAMESPACE v2xloc:: DESTINATION ${V2XLOC_INSTALL_CMAKEDIR}
        FILE v2xloc-targets.cmake COMPONENT core)
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/v2xloc-config.cmake.in
  ${CMAKE_BINARY_DIR}/v2xloc-config.cmake INSTALL_DESTINATION ${V2XLOC_INSTALL_CMAKEDIR})
# 0.x: a minor release may change the API, so only the same major.minor is compatible.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/v2xloc-config-version.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/v2xloc-config.cmake ${CMAKE_BINARY_DIR}/v2xloc-config-version.cmake
        DESTINATION ${V2XLOC_INSTALL_CMAKEDIR} COMPONENT core)
