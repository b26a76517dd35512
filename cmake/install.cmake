# Install rules and the CMake package (SMOKETRACE_INSTALL, on in a top-level build). `cmake --install`
# puts, under the prefix:
#   lib/libsmoketrace.a, include/smoketrace/<layer>/*.hpp   the library and its public headers
#   bin/smoketrace                                          the command line
#   share/smoketrace/                                       six-way textures and scenes, found by the
#                                                           command line relative to its own path
#   lib/cmake/smoketrace/                                   find_package(smoketrace CONFIG) →
#                                                           smoketrace::smoketrace
#   lib/pkgconfig/smoketrace.pc                             pkg-config --cflags --libs smoketrace
#   share/doc/smoketrace/LICENSE
# Nothing of the build machine goes into the package: -march=native (SMOKETRACE_NATIVE) and the warnings
# are directory options of this project, not usage requirements of the target.
include(CMakePackageConfigHelpers)
set(SMOKETRACE_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/smoketrace)
set(SMOKETRACE_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/smoketrace)

install(TARGETS smoketrace EXPORT smoketraceTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS smoketrace_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/smoketrace DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.hpp")
install(FILES ${SMOKETRACE_SOURCE_ASSETS}/sixway.json ${SMOKETRACE_SOURCE_ASSETS}/sixway_pos.png
  ${SMOKETRACE_SOURCE_ASSETS}/sixway_neg.png DESTINATION ${SMOKETRACE_INSTALL_DATADIR})
install(DIRECTORY ${SMOKETRACE_SOURCE_ASSETS}/scenes DESTINATION ${SMOKETRACE_INSTALL_DATADIR})
install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})

install(EXPORT smoketraceTargets NAMESPACE smoketrace:: DESTINATION ${SMOKETRACE_INSTALL_CMAKEDIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/smoketraceConfig.cmake.in
  ${PROJECT_BINARY_DIR}/smoketraceConfig.cmake
  INSTALL_DESTINATION ${SMOKETRACE_INSTALL_CMAKEDIR}
  PATH_VARS SMOKETRACE_INSTALL_DATADIR)
# 0.x: a new minor version may change the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/smoketraceConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/smoketraceConfig.cmake ${PROJECT_BINARY_DIR}/smoketraceConfigVersion.cmake
  DESTINATION ${SMOKETRACE_INSTALL_CMAKEDIR})
# For a build without CMake. Its flags are the target's usage requirements above (GLM_FORCE_XYZW_ONLY,
# -ffp-contract=off: the watertight triangle test inlined into the caller needs it); its prefix is found from
# where the file lies, so that the tree can be moved as the CMake package can.
file(RELATIVE_PATH SMOKETRACE_PC_TO_PREFIX "${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig" "${CMAKE_INSTALL_PREFIX}")
string(REGEX REPLACE "/$" "" SMOKETRACE_PC_TO_PREFIX "${SMOKETRACE_PC_TO_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/smoketrace.pc.in ${PROJECT_BINARY_DIR}/smoketrace.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/smoketrace.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
