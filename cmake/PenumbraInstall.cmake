# install() and export: the test harness and the layers it stands on, the GLSL library, and the
# CMake package (find_package(Penumbra CONFIG), penumbra_add_shader_tests), and
# bin/penumbra-coverage (the GLSL coverage report of the harness's tracefiles). The renderer,
# the scene layer and the other tools are not part of the package.
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
