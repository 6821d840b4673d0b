#!/usr/bin/env bash
# The .deb: `cpack -G DEB` from the build directory into a temporary directory, inspected with dpkg-deb: the files
# (executables, configs under /etc/teleop as conffiles, units, scripts, the library's CMake package), the control
# fields (dependencies from dpkg-shlibdeps), and the unpacked units byte-equal to deploy/systemd/.
#   deb_package_test.sh <build dir> <source dir> <work dir>
set -euo pipefail
build=$1 src=$2 work=$3
fail() { echo "FAILED: $*"; exit 1; }
ok() { echo "  ok: $*"; }
rm -rf "${work}"
mkdir -p "${work}"
(cd "${build}" && cpack -G DEB -B "${work}/cpack" -D CPACK_OUTPUT_FILE_PREFIX="${work}/out") >"${work}/cpack.log" 2>&1 ||
  { tail -20 "${work}/cpack.log"; fail "cpack -G DEB"; }
deb=$(ls "${work}"/out/teleop_*_amd64.deb 2>/dev/null | head -n 1)
[[ -n "${deb}" ]] || fail "no teleop_*_amd64.deb in ${work}/out"
ok "built $(basename "${deb}")"
dpkg-deb -c "${deb}" | awk '{print $6}' >"${work}/contents.txt"
for f in ./usr/bin/teleop-master ./usr/bin/teleop-slave ./usr/bin/teleop-analyze ./usr/bin/teleop-canbus ./usr/bin/teleop-keygen \
         ./usr/bin/teleop-plot ./usr/bin/teleop-canlog ./etc/teleop/master.yaml ./etc/teleop/slave.yaml \
         ./usr/lib/systemd/system/teleop-master.service ./usr/lib/systemd/system/teleop-slave.service \
         ./usr/lib/systemd/system/teleop-can-up@.service ./usr/share/teleop/can-up.sh ./usr/share/teleop/rt-check.sh \
         ./usr/share/teleop/configs/loopback/slave-can.yaml ./usr/share/teleop/wireshark/teleop.lua \
         ./usr/lib/cmake/teleop/teleopConfig.cmake ./usr/include/teleop/device/device_registry.hpp \
         ./usr/share/teleop/robots/arm_7dof.urdf ./usr/share/teleop/robots/stylus_3dof.urdf \
         ./usr/share/teleop/configs/arm/slave-stylus.yaml; do
  grep -qx -- "${f}" "${work}/contents.txt" || fail "dpkg-deb -c: ${f} is not in the package"
done
ok "dpkg-deb -c: executables in /usr/bin, configs in /etc/teleop, units in /usr/lib/systemd/system, tools, CMake package"
if grep -v '^\./\(usr\|etc\)/' "${work}/contents.txt" | grep -v '^\./$' | grep -q .; then
  fail "files outside /usr and /etc: $(grep -v '^\./\(usr\|etc\)/' "${work}/contents.txt" | grep -v '^\./$' | head -3)"
fi
grep -q '^\./usr/local/' "${work}/contents.txt" && fail "files under /usr/local"
ok "nothing outside /usr and /etc, nothing under /usr/local, no build paths"
dpkg-deb -I "${deb}" >"${work}/info.txt"
grep -q "^ Package: teleop$" "${work}/info.txt" || fail "package name"
grep -q "^ Depends:.*libyaml-cpp" "${work}/info.txt" || fail "Depends has no libyaml-cpp (dpkg-shlibdeps)"
grep -q "^ Depends:.*python3-matplotlib" "${work}/info.txt" || fail "Depends has no python3-matplotlib (teleop-plot)"
if grep -q '^TELEOP_DDS:BOOL=ON$' "${build}/CMakeCache.txt"; then
  grep -q "^ Depends:.*libddsc0debian" "${work}/info.txt" || fail "built with DDS but Depends has no libddsc0debian"
  ok "built with DDS (TELEOP_DDS=ON): Depends has libddsc0debian, Cyclone DDS's runtime"
else
  grep -q "^ Depends:.*libddsc" "${work}/info.txt" && fail "built without DDS but Depends names libddsc"
  ok "built without DDS (TELEOP_DDS=OFF): Depends does not name Cyclone DDS"
fi
ok "control: $(grep '^ Depends:' "${work}/info.txt" | sed 's/^ //')"
dpkg-deb -e "${deb}" "${work}/control"
[[ "$(cat "${work}/control/conffiles")" == $'/etc/teleop/master.yaml\n/etc/teleop/slave.yaml' ]] ||
  fail "conffiles: $(cat "${work}/control/conffiles")"
ok "the two /etc/teleop configs are conffiles (an upgrade keeps local edits)"
dpkg-deb -x "${deb}" "${work}/root"
for u in teleop-master.service teleop-slave.service teleop-can-up@.service; do
  cmp -s "${work}/root/usr/lib/systemd/system/${u}" "${src}/deploy/systemd/${u}" || fail "${u} differs from deploy/systemd"
done
"${work}/root/usr/bin/teleop-master" --help | grep -q -- "--config" || fail "the packaged teleop-master does not run"
ok "units byte-equal to deploy/systemd; the packaged teleop-master runs"
echo PASSED
