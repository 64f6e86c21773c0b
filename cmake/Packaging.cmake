# Installation and packages: `cpack` in the build directory writes sinew_VERSION_ARCH.deb (the
# programs), sinew-dev_VERSION_ARCH.deb (the plugin SDK) and a .tar.gz of both.
# Programs find libsinew_core in its private directory through their RUNPATH.
install(TARGETS sinew-run sinew-cohort sinew-make-scene sinew-build-model sinew-make-subject RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" COMPONENT runtime)
if(TARGET sinew)
  install(TARGETS sinew RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}" COMPONENT runtime)
endif()
set(_pkg "${PROJECT_SOURCE_DIR}/packaging")
install(FILES "${_pkg}/io.github.sinew.Sinew.desktop" DESTINATION "${CMAKE_INSTALL_DATADIR}/applications" COMPONENT runtime)
install(FILES "${_pkg}/io.github.sinew.Sinew.svg" DESTINATION "${CMAKE_INSTALL_DATADIR}/icons/hicolor/scalable/apps"
  COMPONENT runtime)
install(FILES "${_pkg}/io.github.sinew.Sinew.metainfo.xml" DESTINATION "${CMAKE_INSTALL_DATADIR}/metainfo" COMPONENT runtime)
install(FILES "${_pkg}/io.github.sinew.Sinew.mime.xml" DESTINATION "${CMAKE_INSTALL_DATADIR}/mime/packages"
  RENAME io.github.sinew.Sinew.xml COMPONENT runtime)
add_custom_command(OUTPUT "${CMAKE_BINARY_DIR}/sinew-run.1.gz"
  COMMAND gzip -9n -c "${_pkg}/sinew-run.1" > "${CMAKE_BINARY_DIR}/sinew-run.1.gz"
  DEPENDS "${_pkg}/sinew-run.1" VERBATIM)
add_custom_target(sinew_man_pages ALL DEPENDS "${CMAKE_BINARY_DIR}/sinew-run.1.gz")
install(FILES "${CMAKE_BINARY_DIR}/sinew-run.1.gz" DESTINATION "${CMAKE_INSTALL_MANDIR}/man1" COMPONENT runtime)
install(FILES README.md docs/sinew-run.md docs/scene-format.md docs/workstation.md docs/plugins.md docs/stability.md
  resources/scene.schema.json DESTINATION "${CMAKE_INSTALL_DATADIR}/doc/sinew" COMPONENT runtime)

set(CPACK_PACKAGE_NAME sinew)
set(CPACK_PACKAGE_VENDOR "Sinew")
set(CPACK_PACKAGE_CONTACT "Sinew developers <sinew-dev@users.noreply.github.com>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "segment organs in MRI and CT with deformable models")
set(CPACK_PACKAGE_DESCRIPTION "Sinew segments organs in 3D medical images with discrete deformable
models (2-simplex meshes) pushed by shape and image forces, many organs at once, on the CPU or an
NVIDIA GPU: a desktop workstation (sinew) and a headless engine (sinew-run).")
set(CPACK_PACKAGE_HOMEPAGE_URL "https://github.com/sinew/sinew")
set(CPACK_GENERATOR "DEB;TGZ")
set(CPACK_COMPONENTS_ALL runtime dev)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME sinew)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)  # Depends from the linked libraries (dpkg-shlibdeps)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS "${CMAKE_BINARY_DIR}/core")
# Read at run time, not linked: the report's fonts; the Colin27 data the demo and examples use.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "fonts-dejavu-core")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "mricron-data")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SUGGESTS "slurm-client")  # sinew-cohort slurm
set(CPACK_DEBIAN_DEV_PACKAGE_NAME sinew-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION devel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
  "sinew (= ${PROJECT_VERSION}), cmake (>= 3.25), g++, libeigen3-dev (>= 3.4), libtbb-dev, qt6-base-dev")
set(CPACK_DEBIAN_DEV_PACKAGE_SUGGESTS "nvidia-cuda-toolkit")
set(CPACK_COMPONENT_RUNTIME_DESCRIPTION "Sinew workstation and headless engine")
set(CPACK_COMPONENT_DEV_DESCRIPTION "Sinew plugin SDK: headers, CMake package, example plugin")
include(CPack)
