include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS sspc ${SSPC_LIBRARY_TARGETS} EXPORT sspcTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(SSPC_BUILD_ENCODER)
  install(DIRECTORY include/sspc DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
else()
  # A decoder-only build installs no header whose functions it does not hold.
  install(DIRECTORY include/sspc DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
          PATTERN encoder.hpp EXCLUDE PATTERN metrics.hpp EXCLUDE)
endif()
if(SSPC_BUILD_APPS)
  install(TARGETS sspc_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()
install(EXPORT sspcTargets NAMESPACE sspc:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/sspc)
configure_package_config_file(cmake/sspcConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/sspcConfig.cmake
  INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/sspc)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/sspcConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/sspcConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/sspcConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/sspc)
