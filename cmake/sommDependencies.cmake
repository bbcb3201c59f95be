# SPDX-License-Identifier: MIT
# The third-party packages of somm's libraries, found the same way when somm is built and when an installed somm is
# imported (sommConfig.cmake includes this file with SOMM_DEPENDENCY_MODE CONFIG, so a missing package makes
# find_package(somm) fail cleanly instead of erroring). Each macro is called only by the target that needs it, so a
# configuration finds only the selected targets' dependencies.
#   somm_find_tbb()      oneTBB         TBB::tbb                       the baker's threads (somm::somm)
#   somm_find_io_deps()  tinygltf, tinyobjloader, stb, libdeflate, xxHash  somm::io
#   somm_find_embree()   Embree 3       embree                         somm::trace
include_guard(GLOBAL)

macro(_somm_find name)
  if(SOMM_DEPENDENCY_MODE STREQUAL "CONFIG")
    find_dependency(${name} ${ARGN})
  else()
    find_package(${name} ${ARGN} REQUIRED)
  endif()
endmacro()

# pkg-config modules as imported targets PkgConfig::somm_<name> (one name for the build and for consumers).
macro(_somm_pkg name module)
  if(NOT TARGET PkgConfig::somm_${name})
    find_package(PkgConfig QUIET)
    if(SOMM_DEPENDENCY_MODE STREQUAL "CONFIG")
      if(PkgConfig_FOUND)
        pkg_check_modules(somm_${name} QUIET IMPORTED_TARGET ${module})
      endif()
      if(NOT TARGET PkgConfig::somm_${name})
        set(${CMAKE_FIND_PACKAGE_NAME}_NOT_FOUND_MESSAGE "somm needs the pkg-config module ${module}")
        set(${CMAKE_FIND_PACKAGE_NAME}_FOUND FALSE)
        return()
      endif()
    else()
      if(NOT PkgConfig_FOUND)
        message(FATAL_ERROR "somm: pkg-config is needed to find ${module}")
      endif()
      pkg_check_modules(somm_${name} REQUIRED IMPORTED_TARGET ${module})
    endif()
  endif()
endmacro()

macro(somm_find_tbb)
  _somm_find(TBB)
endmacro()

macro(somm_find_io_deps)
  _somm_find(TinyGLTF)
  _somm_find(tinyobjloader)
  _somm_pkg(stb stb)
  _somm_pkg(deflate libdeflate)
  _somm_pkg(xxhash libxxhash)
endmacro()

macro(somm_find_embree)
  _somm_find(embree 3)
  _somm_find(TBB)
  _somm_pkg(stb stb)
endmacro()
