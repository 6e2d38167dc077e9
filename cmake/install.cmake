# `cmake --install`: the public API, the libraries behind it, the `servokit` executable, the
# shipped models and a CMake package, so that another project can write
#   find_package(servokit REQUIRED)
#   target_link_libraries(app PRIVATE servokit::servokit)   # #include <servokit/servokit.h>
# Installed layout under the prefix:
#   bin/servokit
#   lib/servokit/libservokit_{data_files,mpi}.so                 (plugins, reports/plugins.h)
#   include/servokit/servokit.h, servokit/base/{errors,vocabulary}.h  (the public API only)
#   lib/libservokit_*.a                                       (position-independent)
#   share/servokit/models/*.yaml                              (the shipped models)
#   lib/cmake/servokit/servokit{Config,ConfigVersion,Targets}.cmake
# The internal libraries are installed and exported only because servokit::servokit links them
# statically; their headers are not, so nothing outside the public API can be included.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(SERVOKIT_LIBRARIES base files modeling numerics analysis trajectories integrators solvers reports studies servokit application)
set(SERVOKIT_PACKAGE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/servokit)

foreach(folder IN LISTS SERVOKIT_LIBRARIES)
  # Exported as servokit::<folder>, the same name as the alias inside this build.
  set_target_properties(servokit_${folder} PROPERTIES EXPORT_NAME ${folder})
endforeach()
install(FILES ${PROJECT_SOURCE_DIR}/servokit/servokit.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/servokit)
# servokit.h includes "base/errors.h", "base/process_group.h" and "base/vocabulary.h": they live
# in the lowest layer, and are installed under include/servokit (on the installed targets'
# include path too), so that the prefix's include/ holds nothing but servokit/.
install(FILES ${PROJECT_SOURCE_DIR}/base/errors.h ${PROJECT_SOURCE_DIR}/base/process_group.h
              ${PROJECT_SOURCE_DIR}/base/vocabulary.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/servokit/base)
list(TRANSFORM SERVOKIT_LIBRARIES PREPEND servokit_ OUTPUT_VARIABLE SERVOKIT_LIBRARY_TARGETS)
install(TARGETS ${SERVOKIT_LIBRARY_TARGETS} EXPORT servokitTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS servokit RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# bin/servokit finds them in ../lib/servokit.
install(TARGETS servokit_data_files LIBRARY DESTINATION ${SERVOKIT_PLUGIN_INSTALL_DIR})
if(TARGET servokit_mpi)
  install(TARGETS servokit_mpi LIBRARY DESTINATION ${SERVOKIT_PLUGIN_INSTALL_DIR})
endif()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/models/
        DESTINATION ${CMAKE_INSTALL_DATADIR}/servokit/models
        FILES_MATCHING PATTERN "*.yaml")

install(EXPORT servokitTargets NAMESPACE servokit:: DESTINATION ${SERVOKIT_PACKAGE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/servokitConfig.cmake.in
  ${PROJECT_BINARY_DIR}/servokitConfig.cmake
  INSTALL_DESTINATION ${SERVOKIT_PACKAGE_DIR}
  PATH_VARS CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/servokitConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/servokitConfig.cmake
              ${PROJECT_BINARY_DIR}/servokitConfigVersion.cmake
        DESTINATION ${SERVOKIT_PACKAGE_DIR})
