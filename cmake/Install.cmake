# cmake --install: the libraries and their public headers, the tools, a CMake package
# (find_package(libbasis CONFIG): targets libbasis::core, ::io, ::image_file, ::brdf, ::lighting,
# ::format, ::study, ::render and libbasis::basis for all of them, dependencies found
# transitively) and a pkg-config file (libbasis.pc). The version is the project's.
include(CMakePackageConfigHelpers)

set(basis_libraries basis_core basis_io basis_image_file basis_brdf basis_lighting basis_format
                    basis_study basis_render)
foreach(target ${basis_libraries})
  string(REPLACE "basis_" "" short ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${short})
endforeach()
add_library(basis INTERFACE)
target_link_libraries(basis INTERFACE ${basis_libraries})
add_library(libbasis::basis ALIAS basis)

set(basis_package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/libbasis)
install(TARGETS ${basis_libraries} basis EXPORT libbasisTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
foreach(folder libbasis/core libbasis/io libbasis/brdf libbasis/lighting libbasis/study
               libbasis/render formats)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${folder}/include/basis
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
install(FILES ${PROJECT_BINARY_DIR}/libbasis/core/generated/basis/core/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/basis/core)
install(EXPORT libbasisTargets NAMESPACE libbasis:: DESTINATION ${basis_package_dir})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/libbasisConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/libbasisConfig.cmake
                              INSTALL_DESTINATION ${basis_package_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/libbasisConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/libbasisConfig.cmake
              ${PROJECT_BINARY_DIR}/libbasisConfigVersion.cmake
        DESTINATION ${basis_package_dir})

# pkg-config: the static libraries in link order, their dependencies as linker flags.
configure_file(${PROJECT_SOURCE_DIR}/cmake/libbasis.pc.in ${PROJECT_BINARY_DIR}/libbasis.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/libbasis.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

if(BASIS_BUILD_TOOLS)
  install(TARGETS qtinfo brdf2qt capture2qt qtmerge qtconvolve qtrender RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  if(BASIS_BUILD_BENCHMARKS)
    install(TARGETS qtbench RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endif()
