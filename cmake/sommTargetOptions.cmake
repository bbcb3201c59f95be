# SPDX-License-Identifier: MIT
# Compile options of somm's own targets. They are applied per target (somm_apply_target_options walks somm's source
# directories after they are configured), so a parent project that uses add_subdirectory(somm) never inherits them.
include_guard(GLOBAL)

# -ffp-contract=off is required, not a preference: bird.cpp's batch kernels and the baker's conservative tests must
# round exactly like the Vulkan reference code (no fused multiply-adds). The public inline headers do not depend on
# it (see docs/integration.md, "Floating-point contraction").
set(SOMM_PRIVATE_OPTIONS -Wall -Wextra -ffp-contract=off)
if(SOMM_WERROR)
  list(APPEND SOMM_PRIVATE_OPTIONS -Werror)
endif()
if(SOMM_POPCNT)
  list(APPEND SOMM_PRIVATE_OPTIONS -mpopcnt)
endif()
set(SOMM_PRIVATE_LINK_OPTIONS)
if(SOMM_SANITIZE)
  # float-cast-overflow: a float converted to an integer type that cannot hold it (clang's `undefined` group has it,
  # GCC's does not; fuzz_gltf found one in getInt).
  list(APPEND SOMM_PRIVATE_OPTIONS -fsanitize=address,undefined,float-cast-overflow -fno-sanitize-recover=all
       -fno-omit-frame-pointer)
  list(APPEND SOMM_PRIVATE_LINK_OPTIONS -fsanitize=address,undefined,float-cast-overflow)
endif()
if(SOMM_BUILD_FUZZ)
  # Everything is built with coverage instrumentation and the sanitizers; only the fuzz targets link libFuzzer's
  # main. -Wno-error: this configuration only exists to fuzz, clang-only warnings must not stop it.
  list(APPEND SOMM_PRIVATE_OPTIONS -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all
       -fno-omit-frame-pointer -g -Wno-error)
  list(APPEND SOMM_PRIVATE_LINK_OPTIONS -fsanitize=address,undefined)
endif()

function(somm_apply_target_options dir)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(type MATCHES "^(STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|OBJECT_LIBRARY|EXECUTABLE)$")
      get_target_property(skip ${t} SOMM_NO_TARGET_OPTIONS)
      if(NOT skip)
        target_compile_options(${t} PRIVATE $<$<COMPILE_LANGUAGE:C,CXX>:${SOMM_PRIVATE_OPTIONS}>)
        if(SOMM_PRIVATE_LINK_OPTIONS AND NOT type STREQUAL "STATIC_LIBRARY" AND NOT type STREQUAL "OBJECT_LIBRARY")
          target_link_options(${t} PRIVATE ${SOMM_PRIVATE_LINK_OPTIONS})
        endif()
      endif()
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(d IN LISTS subdirs)
    somm_apply_target_options(${d})
  endforeach()
endfunction()
