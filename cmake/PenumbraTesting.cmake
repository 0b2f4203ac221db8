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
  string(REPLACE ";" "@@" labels "${D_LABELS}")
  string(REPLACE ";" "@@" environment "${D_ENVIRONMENT}")
  if(NOT D_TIMEOUT)
    set(D_TIMEOUT 0)
  endif()
  set(fail_on_skip OFF)
  if(D_FAIL_ON_SKIP)
    set(fail_on_skip ON)
  endif()
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND "${CMAKE_COMMAND}" "-DEXE=$<TARGET_FILE:${target}>" "-DOUT=${out}"
            "-DPREFIX=${D_PREFIX}" "-DLABELS=${labels}" "-DENVIRONMENT=${environment}"
            "-DTIMEOUT=${D_TIMEOUT}" "-DFAIL_ON_SKIP=${fail_on_skip}"
            "-DWORKING_DIRECTORY=${CMAKE_CURRENT_BINARY_DIR}" -P "${_PENUMBRA_DISCOVER_SCRIPT}"
    BYPRODUCTS "${out}"
    VERBATIM)
  file(WRITE "${include_file}"
    "if(EXISTS \"${out}\")\n"
    "  include(\"${out}\")\n"
    "else()\n"
    "  add_test([==[${D_PREFIX}${target}_NOT_BUILT]==] [==[${target}_NOT_BUILT]==])\n"
    "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${include_file}")
endfunction()
