# penumbra_target_defaults(<target>): warnings, sanitizers and the build-tree paths
# every Penumbra target shares.
function(penumbra_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                           -Wno-sign-conversion -Wnon-virtual-dtor
                                           -Wno-missing-field-initializers)  # Vulkan {sType} idiom
  # GCC 12 at -O3 warns -Wrestrict inside std::string's operator+ once it is inlined (GCC bugs
  # 105329 and 105651, fixed in 13): 17 such warnings in a Release build, none in our code.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(PENUMBRA_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(PENUMBRA_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                             -fno-sanitize-recover=undefined)
    # INTERFACE too: whatever links a sanitized static library needs the runtimes (an installed
    # sanitized build, as CI's example project links it).
    target_link_options(${target} PUBLIC -fsanitize=address,undefined)
  endif()
endfunction()

include(${CMAKE_CURRENT_LIST_DIR}/PenumbraTesting.cmake)

# penumbra_add_test(<name> LABELS <labels...> SOURCES <files...> LIBS <targets...>)
# One CTest test per GoogleTest suite ("<name>:<Suite>"); PENUMBRA_CTEST_PER_TEST=ON gives one per
# test (slower: every test process starts the driver and the validation layer).
# PENUMBRA_TEST_PCH=ON: the test sources share one precompiled header (GoogleTest, gmock, GLM,
# Vulkan and the standard headers). Those sources were two thirds of the CI build's compile time,
# most of it spent parsing the same headers: 505 -> 331 s on 2 cores (.ci/test.sh turns it on,
# with the tests at -O0). Off by default: at -O2 and -O3, GCC 12 reports its known false
# positives inside std::string (-Wstringop-overflow, -Warray-bounds) through the precompiled
# header, which it does not without one.
option(PENUMBRA_TEST_PCH "Precompile the headers every test source includes" OFF)
function(penumbra_test_pch_target)
  if(TARGET penumbra_test_pch OR NOT PENUMBRA_TEST_PCH)
    return()
  endif()
  add_library(penumbra_test_pch OBJECT ${PROJECT_SOURCE_DIR}/cmake/test_pch.cpp)
  penumbra_target_defaults(penumbra_test_pch)
  if(PENUMBRA_TEST_COMPILE_OPTIONS)
    target_compile_options(penumbra_test_pch PRIVATE ${PENUMBRA_TEST_COMPILE_OPTIONS})
  endif()
  target_link_libraries(penumbra_test_pch PRIVATE penumbra::testing)
  # Only headers from outside the project: a test's own namespace lookups stay as they are
  # (penumbra::testing, force-included into a test inside namespace penumbra, would hide
  # ::testing from it).
  target_precompile_headers(penumbra_test_pch PRIVATE
    <algorithm> <cmath> <cstdint> <filesystem> <functional> <limits> <map> <memory> <optional>
    <random> <set> <string> <tuple> <vector> <gtest/gtest.h> <gmock/gmock.h> <glm/glm.hpp>
    <vulkan/vulkan.h>)
endfunction()

function(penumbra_add_test name)
  cmake_parse_arguments(T "" "" "LABELS;SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  penumbra_target_defaults(${name})
  if(PENUMBRA_TEST_COMPILE_OPTIONS)
    target_compile_options(${name} PRIVATE ${PENUMBRA_TEST_COMPILE_OPTIONS})
  endif()
  penumbra_test_pch_target()
  if(TARGET penumbra_test_pch)  # its headers are on every test's include path
    target_precompile_headers(${name} REUSE_FROM penumbra_test_pch)
  endif()
  target_link_libraries(${name} PRIVATE ${T_LIBS} GTest::gtest GTest::gmock)
  target_compile_definitions(${name} PRIVATE
    PENUMBRA_SHADER_DIR="${PENUMBRA_SHADER_DIR}"
    PENUMBRA_TEST_DATA_DIR="${CMAKE_SOURCE_DIR}/tests/data")
  # Debug printf capture (on by default in the test device) matters to shader-function tests;
  # the layer's printf instrumentation made the other GPU tests ~30% slower (ctest -j2 on
  # lavapipe: 77 s -> 101 s), so they run without it.
  set(env ${PENUMBRA_TEST_ENVIRONMENT})
  if(NOT "shader" IN_LIST T_LABELS)
    list(APPEND env "PENUMBRA_DEBUG_PRINTF=0")
  endif()
  if(PENUMBRA_CTEST_PER_TEST)
    penumbra_discover_each_test(${name} LABELS ${T_LABELS} ENVIRONMENT ${env})
  else()
    penumbra_discover_suites(${name} PREFIX "${name}:" LABELS ${T_LABELS} ENVIRONMENT ${env}
                             FAIL_ON_SKIP)
  endif()
endfunction()
