# cmake --install: headers, the libraries as PointLocalization::common, ::lidar, ::recordings, ::schema, ::registration,
# ::client, ::map_updates, ::maps, ::server, the command-line tools, and a package config for find_package.
include(CMakePackageConfigHelpers)

set(pl_exported pl_common pl_lidar pl_recordings pl_schema pl_registration pl_client pl_map_updates pl_maps pl_server)
foreach(target IN LISTS pl_exported)
  string(REGEX REPLACE "^pl_" "" name ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
endforeach()
install(TARGETS ${pl_exported} EXPORT PointLocalizationTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS pl-map pl-server pl-localize pl-sim pl-eval pl-dataset pl-fleet RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

set(pl_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/PointLocalization)
install(EXPORT PointLocalizationTargets NAMESPACE PointLocalization:: DESTINATION ${pl_cmake_dir})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/PointLocalizationConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/PointLocalizationConfig.cmake INSTALL_DESTINATION ${pl_cmake_dir})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/PointLocalizationConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/PointLocalizationConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/PointLocalizationConfigVersion.cmake
        DESTINATION ${pl_cmake_dir})
