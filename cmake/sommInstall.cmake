# SPDX-License-Identifier: MIT
# install(): libraries, headers, the CLI, LICENSE, the CMake package (sommConfig.cmake, version file, exported
# targets somm::somm / somm::io / somm::trace) and somm.pc.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

get_property(SOMM_INSTALL_TARGETS GLOBAL PROPERTY SOMM_INSTALL_TARGETS)
install(TARGETS ${SOMM_INSTALL_TARGETS} EXPORT sommTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/somm DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(TARGET somm)
  install(TARGETS somm RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The shader lookups (docs/shaders.md): somm.glsl and somm.hlsl include somm_lookup.inc from their own directory;
# the example any-hit shaders beside them. Source files, installed whether or not the Vulkan harness is built.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/shaders/ DESTINATION ${CMAKE_INSTALL_DATADIR}/somm/shaders
        FILES_MATCHING PATTERN "*.glsl" PATTERN "*.hlsl" PATTERN "*.inc" PATTERN "*.rahit")

set(SOMM_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/somm)
install(EXPORT sommTargets NAMESPACE somm:: DESTINATION ${SOMM_CMAKE_DIR})
# Which components this install holds, for sommConfig.cmake (it finds only their dependencies).
set(SOMM_HAS_IO OFF)
set(SOMM_HAS_TRACE OFF)
if(TARGET somm_io)
  set(SOMM_HAS_IO ON)
endif()
if(TARGET somm_trace)
  set(SOMM_HAS_TRACE ON)
endif()
get_target_property(SOMM_CORE_TYPE somm_core TYPE)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/sommConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/sommConfig.cmake INSTALL_DESTINATION ${SOMM_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/sommConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/sommConfig.cmake ${PROJECT_BINARY_DIR}/sommConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/sommDependencies.cmake
        DESTINATION ${SOMM_CMAKE_DIR})

# pkg-config: somm.pc is somm::somm (core, baker, C API). A static build lists its private dependencies.
if(SOMM_CORE_TYPE STREQUAL "STATIC_LIBRARY")
  set(SOMM_PC_LIBS_PRIVATE "-lstdc++ -lm")
  set(SOMM_PC_REQUIRES_PRIVATE "tbb")
else()
  set(SOMM_PC_LIBS_PRIVATE "")
  set(SOMM_PC_REQUIRES_PRIVATE "")
endif()
# Relocatable: the prefix is found from the .pc file's own directory (cmake --install --prefix P works).
file(RELATIVE_PATH SOMM_PC_TO_PREFIX "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
string(REGEX REPLACE "/$" "" SOMM_PC_TO_PREFIX "${SOMM_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/somm.pc.in ${PROJECT_BINARY_DIR}/somm.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/somm.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
