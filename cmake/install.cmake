# `cmake --install build --prefix P`: P/bin/hysid, P/lib/libhysid_*.a, the public headers under
# P/include/hysid (each library's FILE_SET HEADERS, in the source layout), the CMake package P/lib/cmake/hysid (find_package(hysid) →
# hysid::hysid and one target per library, dependencies found by hysidConfig.cmake), the model
# files under P/share/hysid/models and the license.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

get_property(hysid_libraries GLOBAL PROPERTY HYSID_LIBRARIES)
# hysid::hysid: every library.
add_library(hysid_all INTERFACE)
target_link_libraries(hysid_all INTERFACE ${hysid_libraries})
set_target_properties(hysid_all PROPERTIES EXPORT_NAME hysid)
add_library(hysid::hysid ALIAS hysid_all)

install(TARGETS ${hysid_libraries} hysid_all random123 EXPORT hysidTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        FILE_SET HEADERS DESTINATION ${HYSID_INSTALL_INCLUDEDIR})
install(TARGETS hysid RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY models/ DESTINATION ${CMAKE_INSTALL_DATADIR}/hysid/models FILES_MATCHING PATTERN "*.toml")
install(FILES LICENSE README.md DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/hysid)
install(EXPORT hysidTargets NAMESPACE hysid:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hysid)

configure_package_config_file(cmake/hysidConfig.cmake.in ${CMAKE_CURRENT_BINARY_DIR}/hysidConfig.cmake
                              INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hysid)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/hysidConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/hysidConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/hysidConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hysid)
