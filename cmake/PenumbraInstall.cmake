# install() and export: the test harness and the layers it stands on, the GLSL library, and the
# CMake package (find_package(Penumbra CONFIG), penumbra_add_shader_tests), and
# bin/penumbra-coverage (the GLSL coverage report of the harness's tracefiles); and, at the end
# (penumbra_install_tools), bin/penumbra-view, bin/penumbra-reference, bin/penumbra-bench and
# bin/penumbra-tune with the renderer's shaders, the shipped scenes and the tools' Python
# package. The renderer and scene libraries are not exported.
include(CMakePackageConfigHelpers)
set(PENUMBRA_INSTALL_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/Penumbra")
set(PENUMBRA_INSTALL_SHADER_DIR "${CMAKE_INSTALL_DATADIR}/penumbra/shaders")

install(TARGETS penumbra_core penumbra_gpu penumbra_shader penumbra_shader_paths_installed
                penumbra_testing penumbra_testing_main
        EXPORT PenumbraTargets
        ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
        INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
foreach(layer core gpu shader testing)
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/include/penumbra/${layer}"
          DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}/penumbra")
endforeach()
install(DIRECTORY "${PROJECT_SOURCE_DIR}/shaders/penumbra"
        DESTINATION "${PENUMBRA_INSTALL_SHADER_DIR}")
install(PROGRAMS "${PROJECT_SOURCE_DIR}/tools/penumbra-coverage" DESTINATION "${CMAKE_INSTALL_BINDIR}")
install(EXPORT PenumbraTargets NAMESPACE Penumbra:: DESTINATION "${PENUMBRA_INSTALL_CMAKE_DIR}")
configure_package_config_file(
  "${PROJECT_SOURCE_DIR}/cmake/PenumbraConfig.cmake.in"
  "${PROJECT_BINARY_DIR}/PenumbraConfig.cmake"
  INSTALL_DESTINATION "${PENUMBRA_INSTALL_CMAKE_DIR}"
  PATH_VARS PENUMBRA_INSTALL_SHADER_DIR)
write_basic_package_version_file("${PROJECT_BINARY_DIR}/PenumbraConfigVersion.cmake"
                                 COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/PenumbraConfig.cmake"
              "${PROJECT_BINARY_DIR}/PenumbraConfigVersion.cmake"
              "${PROJECT_SOURCE_DIR}/cmake/PenumbraTesting.cmake"
              "${PROJECT_SOURCE_DIR}/cmake/PenumbraDiscoverSuites.cmake"
        DESTINATION "${PENUMBRA_INSTALL_CMAKE_DIR}")

# The viewer and the reference as installed tools (issue 36), with the renderer's shaders and the
# shipped scenes: an installed tool finds share/penumbra beside its bin/ from its own path
# (installed_share_dir in penumbra/core/file.hpp), so a moved prefix works. Called from the top
# level after runtime/ and tools/ define the targets.
function(penumbra_install_tools)
  foreach(tool penumbra-view penumbra-reference)
    if(TARGET ${tool})
      install(TARGETS ${tool} RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
    endif()
  endforeach()
  # Every shader the renderer compiles (shaders/render, the passes' .comp files at the top, the
  # library again): the tools read them from here.
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/shaders/" DESTINATION "${PENUMBRA_INSTALL_SHADER_DIR}")
  install(DIRECTORY "${PROJECT_SOURCE_DIR}/scenes/"
          DESTINATION "${CMAKE_INSTALL_DATADIR}/penumbra/scenes")
  # penumbra-bench, penumbra-tune (and what they run: penumbra-extremes, penumbra-texel-rate;
  # penumbra-cluster for their --cluster) with their Python package in share/penumbra/python: a
  # script finds the package, the tools beside it in bin/ and the scenes from its own real path.
  if(TARGET penumbra-view AND TARGET penumbra-reference)
    install(TARGETS penumbra-texel-rate RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
    foreach(script penumbra-bench penumbra-tune penumbra-extremes penumbra-cluster)
      install(PROGRAMS "${PROJECT_SOURCE_DIR}/tools/${script}" DESTINATION "${CMAKE_INSTALL_BINDIR}")
    endforeach()
    install(DIRECTORY "${PROJECT_SOURCE_DIR}/tools/penumbra"
            DESTINATION "${CMAKE_INSTALL_DATADIR}/penumbra/python" FILES_MATCHING PATTERN "*.py"
            PATTERN "__pycache__" EXCLUDE)
    # The commit their results name (git is not asked from a prefix): the tree's at install time.
    install(CODE "
      execute_process(COMMAND git -C \"${PROJECT_SOURCE_DIR}\" rev-parse --short=12 HEAD
                      OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
      file(WRITE \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DATADIR}/penumbra/commit\"
           \"\${commit}\\n\")")
  endif()
endfunction()
