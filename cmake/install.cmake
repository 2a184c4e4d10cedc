# `cmake --install build` puts the binary, the man page and the documentation of the
# bundled profiles (their sources, as examples for writing one) in place;
# `cpack` in the build directory makes a .deb of the same files.
include(GNUInstallDirs)
install(TARGETS rtuscope RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${PROJECT_SOURCE_DIR}/docs/rtuscope.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/docs/formats.md
              ${PROJECT_SOURCE_DIR}/docs/profiles.md ${PROJECT_SOURCE_DIR}/docs/long-runs.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
# The systemd unit of docs/long-runs.md, for the administrator to copy and edit.
install(FILES ${PROJECT_SOURCE_DIR}/contrib/rtuscope-record@.service
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/contrib)
install(FILES ${PROJECT_SOURCE_DIR}/profiles/README.md ${RTUSCOPE_BUNDLED_PROFILES}
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/profiles)
# uPlot's MIT licence: the binary carries uPlot, inlined into every report page.
install(FILES ${PROJECT_SOURCE_DIR}/third_party/uplot/LICENSE
        DESTINATION ${CMAKE_INSTALL_DOCDIR}/third_party/uplot)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME rtuscope)
set(CPACK_PACKAGE_CONTACT "rtuscope maintainers <rtuscope@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${PROJECT_DESCRIPTION}")
set(CPACK_DEBIAN_PACKAGE_SECTION electronics)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
# The shared libraries the binary links (libpcap, libmodbus, libfmt, ...) become the
# package's dependencies, as dpkg-shlibdeps finds them.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
include(CPack)
