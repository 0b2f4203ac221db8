# penumbra_discover_suites(<target> [PREFIX <p>] [LABELS <l>...] [ENVIRONMENT <VAR=value>...]
#                          [TIMEOUT <s>] [FAIL_ON_SKIP])
# Registers a GoogleTest executable with CTest as one test per suite ("<p><Suite>", running
# --gtest_filter=<Suite>.*), listed after every link (cmake/PenumbraDiscoverSuites.cmake). A
# process per suite instead of per test: the Vulkan driver, the validation layer and the shaders
# start once per suite. gtest_discover_tests gives one test per test where that is wanted.
set(_PENUMBRA_DISCOVER_SCRIPT "${CMAKE_CURRENT_LIST_DIR}/PenumbraDiscoverSuites.cmake")

function(penumbra_discover_suites target)
  cmake_parse_arguments(D "FAIL_ON_SKIP" "PREFIX;TIMEOUT" "LABELS;ENVIRONMENT" ${ARGN})
  set(out "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
  set(include_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites_include.cmake")
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND "${CMAKE_COMMAND}" "-DEXE=$<TARGET_FILE:${target}>" "-DOUT=${out}"
            "-DWORKING_DIRECTORY=${CMAKE_CURRENT_BINARY_DIR}" -P "${_PENUMBRA_DISCOVER_SCRIPT}"
    BYPRODUCTS "${out}"
    VERBATIM)
  # The properties are this configuration's: written now, applied to whatever suites the last
  # link listed.
  set(props "WORKING_DIRECTORY [==[${CMAKE_CURRENT_BINARY_DIR}]==]")
  if(D_FAIL_ON_SKIP)
    string(APPEND props " FAIL_REGULAR_EXPRESSION [==[\\[  SKIPPED \\]]==]")
  endif()
  if(D_LABELS)
    string(APPEND props " LABELS [==[${D_LABELS}]==]")
  endif()
  if(D_ENVIRONMENT)
    string(APPEND props " ENVIRONMENT [==[${D_ENVIRONMENT}]==]")
  endif()
  if(D_TIMEOUT AND NOT D_TIMEOUT EQUAL 0)
    string(APPEND props " TIMEOUT ${D_TIMEOUT}")
  endif()
  file(WRITE "${include_file}"
    "if(EXISTS \"${out}\")\n"
    "  include(\"${out}\")\n"
    "  foreach(suite IN LISTS PENUMBRA_SUITES)\n"
    "    add_test(\"${D_PREFIX}\${suite}\" \"\${PENUMBRA_SUITES_EXE}\" \"--gtest_filter=\${suite}.*\")\n"
    "    set_tests_properties(\"${D_PREFIX}\${suite}\" PROPERTIES ${props})\n"
    "  endforeach()\n"
    "else()\n"
    "  add_test([==[${D_PREFIX}${target}_NOT_BUILT]==] [==[${target}_NOT_BUILT]==])\n"
    "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${include_file}")
endfunction()

# penumbra_discover_each_test(<target> [LABELS <l>...] [ENVIRONMENT <VAR=value>...]
#                             [TIMEOUT <s>])
# One CTest test per GoogleTest test, "<target>:<Suite>.<Test>" (gtest_discover_tests), with
# the labels and environment applied after discovery: gtest_discover_tests(PROPERTIES ...)
# flattens list values (two labels, two variables).
function(penumbra_discover_each_test target)
  cmake_parse_arguments(D "" "TIMEOUT" "LABELS;ENVIRONMENT" ${ARGN})
  include(GoogleTest)
  gtest_discover_tests(${target} TEST_PREFIX "${target}:" DISCOVERY_TIMEOUT 60)
  set(script "${CMAKE_CURRENT_BINARY_DIR}/${target}_properties.cmake")
  set(timeout "")
  if(D_TIMEOUT)
    set(timeout " TIMEOUT ${D_TIMEOUT}")
  endif()
  file(WRITE "${script}"
    "foreach(t IN LISTS ${target}_TESTS)\n"
    "  set_tests_properties(\"\${t}\" PROPERTIES LABELS \"${D_LABELS}\"\n"
    "    ENVIRONMENT \"${D_ENVIRONMENT}\"${timeout})\n"
    "endforeach()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${script}")
endfunction()

# penumbra_add_shader_tests(<name> SOURCES <files>... [SHADER_DIRS <dirs>...] [LABELS <l>...]
#                           [LIBS <targets>...] [TIMEOUT <s>] [PER_TEST] [COVERAGE <dir>])
# Builds a GoogleTest executable of shader-function tests linked with Penumbra::testing_main and
# registers it with CTest, one test per suite (PER_TEST: one per test). Every test runs with the
# Khronos validation layer on (PENUMBRA_VALIDATION=1), finds the GLSL in SHADER_DIRS (relative
# to the current source directory; searched before Penumbra's own shader library) and keeps
# its SPIR-V and Mesa caches in <build>/penumbra-cache, so that a warm run starts no glslang.
# COVERAGE <dir>: GLSL line/branch coverage (PENUMBRA_COVERAGE): each test process writes an
# LCOV tracefile into <dir> (relative to the current binary directory); merge them with
# tools/penumbra-coverage, or lcov -a, and genhtml.
function(penumbra_add_shader_tests name)
  cmake_parse_arguments(T "PER_TEST" "TIMEOUT;COVERAGE" "SOURCES;SHADER_DIRS;LABELS;LIBS" ${ARGN})
  if(NOT T_SOURCES)
    message(FATAL_ERROR "penumbra_add_shader_tests(${name}): SOURCES is empty")
  endif()
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE Penumbra::testing_main ${T_LIBS})
  set(dirs "")
  foreach(dir IN LISTS T_SHADER_DIRS)
    get_filename_component(dir "${dir}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    if(NOT IS_DIRECTORY "${dir}")
      message(FATAL_ERROR "penumbra_add_shader_tests(${name}): SHADER_DIRS: '${dir}' is not a "
                          "directory")
    endif()
    list(APPEND dirs "${dir}")
  endforeach()
  string(JOIN ":" path ${dirs})
  # The same directories compiled in (testing::set_default_shader_path, before main()): the
  # executable finds its GLSL when run directly too; PENUMBRA_SHADER_PATH still overrides them.
  if(path)
    set(source "${CMAKE_CURRENT_BINARY_DIR}/${name}_shader_path.cpp")
    file(CONFIGURE OUTPUT "${source}" CONTENT
"// Generated by penumbra_add_shader_tests(${name}): its SHADER_DIRS.
#include <penumbra/testing/shader_function.hpp>
namespace {
[[maybe_unused]] const bool penumbra_shader_path_set =
    penumbra::testing::set_default_shader_path(R\"penumbra(${path})penumbra\");
}  // namespace
")
    target_sources(${name} PRIVATE "${source}")
  endif()
  set(env "PENUMBRA_VALIDATION=1"
          "PENUMBRA_SHADER_CACHE_DIR=${CMAKE_BINARY_DIR}/penumbra-cache/spirv"
          "MESA_SHADER_CACHE_DIR=${CMAKE_BINARY_DIR}/penumbra-cache/mesa")
  if(path)
    list(APPEND env "PENUMBRA_SHADER_PATH=${path}")
  endif()
  if(PENUMBRA_PACKAGE_SHADER_DIR)  # set by PenumbraConfig.cmake: the package's own copy
    list(APPEND env "PENUMBRA_SHADER_DIR=${PENUMBRA_PACKAGE_SHADER_DIR}")
  endif()
  if(T_COVERAGE)
    get_filename_component(coverage "${T_COVERAGE}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_BINARY_DIR}")
    list(APPEND env "PENUMBRA_COVERAGE=${coverage}")
  endif()
  if(T_PER_TEST)
    penumbra_discover_each_test(${name} LABELS ${T_LABELS} ENVIRONMENT ${env}
                                TIMEOUT "${T_TIMEOUT}")
  else()
    penumbra_discover_suites(${name} PREFIX "${name}:" LABELS ${T_LABELS} ENVIRONMENT ${env}
                             TIMEOUT "${T_TIMEOUT}")
  endif()
endfunction()
