# SPDX-License-Identifier: Apache-2.0
# What `cmake --install` puts beside the two executables (their install() rules are in
# server/CMakeLists.txt and client/CMakeLists.txt), and the Debian package CPack makes of it:
#   cmake --build build --target scanprep-server scanprep
#   cpack --config build/CPackConfig.cmake -B build/package      # build/package/scanprep_*.deb
# tools/check-package.sh builds the .deb and checks its contents (docs/deployment.md, "Install").
include(GNUInstallDirs)

# `ninja install` and cpack build nothing first (not the tests and benchmarks of `all`): build
# the two executables, then install; a missing one fails the install ("cannot find").
set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON)

# The systemd unit, its ExecStart at the install's own bindir (and the docs' path): CPack installs
# under /usr while `cmake --install` keeps CMAKE_INSTALL_PREFIX (systemd reads
# /usr/local/lib/systemd/system too), so the paths are written at install time, then installed.
set(SCANPREP_UNIT_IN "${PROJECT_SOURCE_DIR}/deploy/systemd/scanprep-server.service.in")
set(SCANPREP_UNIT "${PROJECT_BINARY_DIR}/deploy/scanprep-server.service")
install(CODE "
  set(SCANPREP_BINDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  set(SCANPREP_DOCDIR \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_DOCDIR}\")
  configure_file(\"${SCANPREP_UNIT_IN}\" \"${SCANPREP_UNIT}\" @ONLY)
")
install(FILES "${SCANPREP_UNIT}" DESTINATION lib/systemd/system)

# Docs: the license, the README and docs/*.md, and the unit's example environment file.
install(FILES LICENSE README.md deploy/systemd/scanprep-server.default
  DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR} FILES_MATCHING PATTERN "*.md"
  PATTERN images EXCLUDE)

# The .deb: `cpack -G DEB` (the default generator here).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME scanprep)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR "scanprep")
# The Maintainer field: set it for a release (cmake -DCPACK_PACKAGE_CONTACT="Name <address>").
if(NOT CPACK_PACKAGE_CONTACT)
  set(CPACK_PACKAGE_CONTACT "scanprep maintainers <maintainers@scanprep.invalid>")
endif()
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
  "point-cloud cleanup as a gRPC service (scanprep-server) and its command-line client")
# The extended description (CPack indents each line; the summary above is the first line).
set(CPACK_PACKAGE_DESCRIPTION
  "scanprep-server cleans point clouds sent by an MES or the scanprep CLI: outliers, normals,
correction, simplification, and a report on the scan's health. The systemd unit
scanprep-server.service serves plaintext gRPC on loopback until /etc/default/scanprep-server
says otherwise; it is not enabled on install.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # scanprep_0.1.0_amd64.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# Depends from the executables' shared libraries (dpkg-shlibdeps, in dpkg-dev).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_RESOURCE_FILE_LICENSE "${PROJECT_SOURCE_DIR}/LICENSE")
include(CPack)
