# SPDX-License-Identifier: MIT
# somm as a consumer sees it (ctest runs this with cmake -P):
#  1. cmake --install into a temporary prefix; the examples find it with find_package(somm), build (C11, C++17) and
#     run; their buffers are byte-identical to `somm bake` + `somm export` on the same input (the OBJ the C example
#     writes);
#  2. the C example built with pkg-config alone (somm.pc) gives the same bytes;
#  3. a parent project with add_subdirectory(somm) (shared libraries, empty build type, its own flags) builds the
#     examples without inheriting somm's build type or flags and gets the same bytes.
# Variables: SOMM_SOURCE_DIR, SOMM_BINARY_DIR, SOMM_CLI, WORK_DIR, GENERATOR, C_COMPILER, CXX_COMPILER, LAUNCHER.
cmake_minimum_required(VERSION 3.22)

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

function(expect_same_buffers dir reference what)
  foreach(f array-0/data.bin array-0/triangles.bin geometry-0/index.bin)
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${dir}/${f} ${reference}/${f}
                    RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "${what}: ${f} differs from `somm bake` + `somm export`")
    endif()
  endforeach()
  message(STATUS "${what}: array-0/data.bin, triangles.bin, geometry-0/index.bin byte-identical to somm bake + export")
endfunction()

set(launcher)
if(LAUNCHER)
  set(launcher -DCMAKE_C_COMPILER_LAUNCHER=${LAUNCHER} -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

# ---- 1. install + find_package ----
run(${CMAKE_COMMAND} --install ${SOMM_BINARY_DIR} --prefix ${WORK_DIR}/prefix)
foreach(f include/somm/somm.h include/somm/bake.h lib/cmake/somm/sommConfig.cmake
          lib/cmake/somm/sommConfigVersion.cmake lib/pkgconfig/somm.pc share/doc/somm/LICENSE
          share/somm/shaders/somm.glsl share/somm/shaders/somm.hlsl share/somm/shaders/somm_lookup.inc
          share/somm/shaders/examples/anyhit_succinct_tree.rahit)
  if(NOT EXISTS ${WORK_DIR}/prefix/${f})
    message(FATAL_ERROR "the install lacks ${f}")
  endif()
endforeach()
# The installed shaders are self-contained: the harness kernels compile against them alone (when glslang is here).
find_program(GLSLANG glslangValidator)
if(GLSLANG)
  set(shaders ${WORK_DIR}/prefix/share/somm/shaders)
  run(${GLSLANG} -V --target-env vulkan1.0 -I${shaders} -o ${WORK_DIR}/check_glsl.spv
      ${SOMM_SOURCE_DIR}/src/gpu/kernels/check.comp)
  run(${GLSLANG} -V -D --target-env vulkan1.0 -S comp -e main -I${shaders} -o ${WORK_DIR}/check_hlsl.spv
      ${SOMM_SOURCE_DIR}/src/gpu/kernels/check.hlsl)
endif()
run(${CMAKE_COMMAND} -S ${SOMM_SOURCE_DIR}/examples -B ${WORK_DIR}/find -G ${GENERATOR}
    -DCMAKE_C_COMPILER=${C_COMPILER} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/find)
run(${WORK_DIR}/find/bake_from_memory ${WORK_DIR}/c)
message(STATUS "bake_from_memory (C11, find_package):\n${run_output}")
string(FIND "${run_output}" "data buffer" pos)
if(pos LESS 0)
  message(FATAL_ERROR "bake_from_memory printed no buffer sizes")
endif()
run(${WORK_DIR}/find/bake_from_memory_cpp17 ${WORK_DIR}/cpp17)
message(STATUS "bake_from_memory_cpp17 (C++17, find_package):\n${run_output}")
# The Embree any-hit example (somm::trace): traced hits identical to the texture test, fewer alpha tests.
if(NOT EXISTS ${WORK_DIR}/find/embree_any_hit)
  message(FATAL_ERROR "find_package(somm COMPONENTS trace) did not give the embree_any_hit example")
endif()
run(${WORK_DIR}/find/embree_any_hit)
message(STATUS "embree_any_hit (C++17, find_package):\n${run_output}")
string(FIND "${run_output}" "differ from the texture test: flat 0, sdag 0" pos)
if(pos LESS 0)
  message(FATAL_ERROR "embree_any_hit: traced hits differ from the texture test")
endif()

# The same input through the CLI.
run(${SOMM_CLI} bake ${WORK_DIR}/c/scene.obj -o ${WORK_DIR}/cli.somm)
run(${SOMM_CLI} export ${WORK_DIR}/cli.somm --dir ${WORK_DIR}/cli)
expect_same_buffers(${WORK_DIR}/c ${WORK_DIR}/cli "C11 consumer (find_package)")
expect_same_buffers(${WORK_DIR}/cpp17 ${WORK_DIR}/cli "C++17 consumer (find_package)")

# ---- 2. pkg-config ----
find_program(PKG_CONFIG pkg-config REQUIRED)
set(ENV{PKG_CONFIG_PATH} ${WORK_DIR}/prefix/lib/pkgconfig)
run(${PKG_CONFIG} --cflags --libs --static somm)
string(STRIP "${run_output}" pc_flags)
separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
file(MAKE_DIRECTORY ${WORK_DIR}/pc)
run(${C_COMPILER} -std=c11 -I${SOMM_SOURCE_DIR}/examples ${SOMM_SOURCE_DIR}/examples/bake_from_memory.c ${pc_flags}
    -o ${WORK_DIR}/pc/bake_from_memory)
run(${WORK_DIR}/pc/bake_from_memory ${WORK_DIR}/pc-out)
expect_same_buffers(${WORK_DIR}/pc-out ${WORK_DIR}/cli "C11 consumer (pkg-config)")

# ---- 3. add_subdirectory, shared libraries, empty build type, the parent's own flags ----
# First with somm's defaults (configure only: somm::somm alone, no Embree, no I/O packages looked for), then with
# somm::trace as well, built and run.
run(${CMAKE_COMMAND} -S ${SOMM_SOURCE_DIR}/tests/consumer/parent -B ${WORK_DIR}/parent-default -G ${GENERATOR}
    -DCMAKE_C_COMPILER=${C_COMPILER} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher}
    -DSOMM_SOURCE_DIR=${SOMM_SOURCE_DIR} -DBUILD_SHARED_LIBS=ON
    "-DCMAKE_C_FLAGS=-Wall -O1" "-DCMAKE_CXX_FLAGS=-Wall -O1" "-DPARENT_EXPECTED_FLAGS=-Wall -O1")
run(${CMAKE_COMMAND} -S ${SOMM_SOURCE_DIR}/tests/consumer/parent -B ${WORK_DIR}/parent -G ${GENERATOR}
    -DCMAKE_C_COMPILER=${C_COMPILER} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher}
    -DSOMM_SOURCE_DIR=${SOMM_SOURCE_DIR} -DBUILD_SHARED_LIBS=ON -DSOMM_BUILD_TRACE=ON
    "-DCMAKE_C_FLAGS=-Wall -O1" "-DCMAKE_CXX_FLAGS=-Wall -O1" "-DPARENT_EXPECTED_FLAGS=-Wall -O1")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/parent)
run(${WORK_DIR}/parent/examples/embree_any_hit)
string(FIND "${run_output}" "differ from the texture test: flat 0, sdag 0" pos)
if(pos LESS 0)
  message(FATAL_ERROR "embree_any_hit (add_subdirectory): traced hits differ from the texture test")
endif()
if(NOT EXISTS ${WORK_DIR}/parent/somm/src/libsomm_core.so.0)
  message(FATAL_ERROR "BUILD_SHARED_LIBS=ON did not build libsomm_core.so")
endif()
run(${WORK_DIR}/parent/examples/bake_from_memory ${WORK_DIR}/sub)
run(${WORK_DIR}/parent/examples/bake_from_memory_cpp17 ${WORK_DIR}/sub-cpp17)
expect_same_buffers(${WORK_DIR}/sub ${WORK_DIR}/cli "C11 consumer (add_subdirectory, shared)")
expect_same_buffers(${WORK_DIR}/sub-cpp17 ${WORK_DIR}/cli "C++17 consumer (add_subdirectory, shared)")
file(REMOVE_RECURSE ${WORK_DIR})
