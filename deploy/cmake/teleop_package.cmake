# What a deployed machine gets besides the executables and the library (docs/deployment.md): the rig configs, the
# systemd units, the host scripts, the plot tool, the Wireshark dissector, the docs; and the .deb that carries it all
# (`cpack -G DEB` in the build directory, tests/deploy/package_test.sh).
#
# Layout under the install prefix (the .deb's prefix is /usr):
#   bin/teleop-plot, bin/teleop-canlog        run CSV -> PNGs; emulated-bus capture -> candump log
#   lib/systemd/system/teleop-*.service       the units (they name /usr/bin/teleop-* and /etc/teleop/*.yaml)
#   share/teleop/configs/**.yaml              every rig config
#   share/teleop/robots/*.urdf                the shipped robots (docs/arms.md); the arm configs name them as
#                                             ../../robots/<file>.urdf, which resolves here from configs/<rig>/
#   share/teleop/can-up.sh, rt-check.sh       host scripts
#   share/teleop/motors/mit-models.yaml       the MIT-mode motor models (teleop-motor, arm joints)
#   share/teleop/wireshark/teleop.lua         the dissector
#   share/doc/teleop/*.md                     the docs (and figures/*.png, the gallery's images)
#   /etc/teleop/{master,slave}.yaml           the loopback rig over UDP, what the units start with (prefix/etc/teleop
#                                             when the prefix is not /usr, so a test install never writes /etc)

set(TELEOP_DEPLOY_SOURCE ${PROJECT_SOURCE_DIR}/deploy)

install(FILES ${TELEOP_DEPLOY_SOURCE}/systemd/teleop-master.service ${TELEOP_DEPLOY_SOURCE}/systemd/teleop-slave.service
              ${TELEOP_DEPLOY_SOURCE}/systemd/teleop-can-up@.service
        DESTINATION lib/systemd/system)
install(DIRECTORY ${TELEOP_DEPLOY_SOURCE}/configs/ DESTINATION ${CMAKE_INSTALL_DATADIR}/teleop/configs
        FILES_MATCHING PATTERN "*.yaml" PATTERN "*.csv")
install(DIRECTORY ${TELEOP_DEPLOY_SOURCE}/robots/ DESTINATION ${CMAKE_INSTALL_DATADIR}/teleop/robots
        FILES_MATCHING PATTERN "*.urdf")
install(PROGRAMS ${TELEOP_DEPLOY_SOURCE}/can-up.sh ${TELEOP_DEPLOY_SOURCE}/rt-check.sh
        DESTINATION ${CMAKE_INSTALL_DATADIR}/teleop)
install(PROGRAMS ${TELEOP_DEPLOY_SOURCE}/teleop-plot ${TELEOP_DEPLOY_SOURCE}/teleop-canlog ${TELEOP_DEPLOY_SOURCE}/teleop-session
        DESTINATION ${CMAKE_INSTALL_BINDIR})
install(FILES ${TELEOP_DEPLOY_SOURCE}/motors/mit-models.yaml DESTINATION ${CMAKE_INSTALL_DATADIR}/teleop/motors)
install(FILES ${TELEOP_DEPLOY_SOURCE}/wireshark/teleop.lua DESTINATION ${CMAKE_INSTALL_DATADIR}/teleop/wireshark)
file(GLOB TELEOP_DOCS ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES ${TELEOP_DOCS} DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/rigs DESTINATION ${CMAKE_INSTALL_DOCDIR} FILES_MATCHING PATTERN "*.md")
# The images of docs/figures.md (deploy/figures.sh), so the installed gallery shows them.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/figures DESTINATION ${CMAKE_INSTALL_DOCDIR} FILES_MATCHING PATTERN "*.png")

# /etc/teleop: decided at install time, from the prefix the install runs with (cpack installs with prefix /usr into
# DESTDIR, which file(INSTALL) prepends to the absolute path).
install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    set(teleop_etc /etc/teleop)
  else()
    set(teleop_etc \"\${CMAKE_INSTALL_PREFIX}/etc/teleop\")
  endif()
  file(INSTALL \"${TELEOP_DEPLOY_SOURCE}/configs/loopback/master-udp.yaml\" DESTINATION \"\${teleop_etc}\"
       RENAME master.yaml)
  file(INSTALL \"${TELEOP_DEPLOY_SOURCE}/configs/loopback/slave-udp.yaml\" DESTINATION \"\${teleop_etc}\"
       RENAME slave.yaml)
")

# The .deb: one package with the executables, the library for find_package(teleop), configs, units, tools.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME teleop)
set(CPACK_PACKAGE_VENDOR "teleop")
set(CPACK_PACKAGE_CONTACT "teleop maintainers <teleop@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "bilateral teleoperation over a fieldbus: teleop-master, teleop-slave, configs, systemd units")
set(CPACK_PACKAGE_DESCRIPTION
    "Two processes exchange position, velocity and force at 0.5-4 kHz over UDP or CAN, each running its half of the "
    "three-channel law with a forbidden-region virtual fixture. Includes teleop-analyze (stability), teleop-canbus "
    "(emulated CAN bus), teleop-keygen (the link's pre-shared key), teleop-plot, systemd units, rig configs, the static "
    "library and CMake package.")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_SET_DESTDIR ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# teleop-plot, can-up.sh, rt-check.sh; the -dev packages a find_package(teleop) consumer needs.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3, python3-matplotlib, iproute2")
# The arm backend and teleop-arm (docs/arms.md) load KDL and urdfdom's runtimes (named here as well as by
# dpkg-shlibdeps, as for Cyclone DDS below).
string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", liborocos-kdl1.5, liburdfdom-model3.0")
# With the DDS bridge (TELEOP_DDS) the processes and teleop-supervise load Cyclone DDS's runtime, Debian 12's
# libddsc0debian (named here as well as by dpkg-shlibdeps, so the dependency stays when the bridge is linked
# statically or shlibdeps is turned off).
if(TELEOP_DDS)
  string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", libddsc0debian")
endif()
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "can-utils, tshark, libeigen3-dev, libboost-dev, libyaml-cpp-dev, libspdlog-dev, liborocos-kdl-dev, liburdfdom-dev")
configure_file(${TELEOP_DEPLOY_SOURCE}/debian/conffiles ${PROJECT_BINARY_DIR}/debian/conffiles COPYONLY)
configure_file(${TELEOP_DEPLOY_SOURCE}/debian/postinst ${PROJECT_BINARY_DIR}/debian/postinst COPYONLY)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_BINARY_DIR}/debian/conffiles ${PROJECT_BINARY_DIR}/debian/postinst)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_OUTPUT_FILE_PREFIX ${PROJECT_BINARY_DIR}/packages)
include(CPack)

# build/bin/teleop-plot, teleop-canlog and teleop-session beside the executables (links to deploy/, so edits need no rebuild).
foreach(tool teleop-plot teleop-canlog teleop-session)
  file(MAKE_DIRECTORY ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
  file(CREATE_LINK ${TELEOP_DEPLOY_SOURCE}/${tool} ${CMAKE_RUNTIME_OUTPUT_DIRECTORY}/${tool} SYMBOLIC)
endforeach()
