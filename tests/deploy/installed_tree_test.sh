#!/usr/bin/env bash
# The installed tree: `cmake --install` into a temporary prefix, then deploy/examples/custom_backend (a device
# backend registered from outside the tree, and spring-master, its own teleop-master through ProcessMain) configured
# with find_package(teleop) against that prefix only, built, run alone and as a process pair with teleop-slave.
# Also: the layout the docs promise, and the installed processes starting on the installed configs.
#   installed_tree_test.sh <build dir> <source dir> <work dir>
set -euo pipefail
build=$1 src=$2 work=$3
fail() { echo "FAILED: $*"; exit 1; }
ok() { echo "  ok: $*"; }
rm -rf "${work}"
mkdir -p "${work}"
prefix="${work}/prefix"

cmake --install "${build}" --prefix "${prefix}" >"${work}/install.log" || fail "cmake --install (see ${work}/install.log)"
for f in bin/teleop-master bin/teleop-slave bin/teleop-analyze bin/teleop-canbus bin/teleop-plot bin/teleop-keygen \
         lib/cmake/teleop/teleopConfig.cmake lib/cmake/teleop/teleopConfigVersion.cmake \
         lib/cmake/teleop/teleopTargets.cmake lib/libteleop_device.a include/teleop/device/device_registry.hpp \
         include/teleop/proto/codec.hpp etc/teleop/master.yaml etc/teleop/slave.yaml \
         lib/systemd/system/teleop-master.service lib/systemd/system/teleop-slave.service \
         share/teleop/can-up.sh share/teleop/rt-check.sh share/teleop/wireshark/teleop.lua \
         share/teleop/configs/loopback/master-udp.yaml share/doc/teleop/deployment.md \
         share/teleop/robots/arm_7dof.urdf share/teleop/robots/stylus_3dof.urdf bin/teleop-arm; do
  [[ -e "${prefix}/${f}" ]] || fail "not installed: ${f}"
done
ok "installed: executables, library + CMake package, headers, /etc/teleop configs, units, scripts, dissector, docs"
cmp -s "${prefix}/etc/teleop/master.yaml" "${src}/deploy/configs/loopback/master-udp.yaml" ||
  fail "etc/teleop/master.yaml is not the loopback rig's UDP config"
ok "etc/teleop/master.yaml is the loopback rig over UDP"
"${prefix}/bin/teleop-analyze" check --config "${prefix}/etc/teleop/slave.yaml" | grep -q "is stable" ||
  fail "the installed teleop-analyze does not pass the installed slave config"
ok "the installed teleop-analyze checks the installed slave config: stable"
# The arm rigs name their URDF relative to the config (../../robots/<file>.urdf): in the installed tree that is
# share/teleop/robots, so the installed configs run from the installed tree without edits.
for rig in arm/master-stylus arm/slave-stylus arm/master-twin arm/slave-twin; do
  out=$("${prefix}/bin/teleop-arm" check --config "${prefix}/share/teleop/configs/${rig}.yaml" 2>&1) ||
    { echo "${out}"; fail "the installed teleop-arm check on the installed ${rig}.yaml"; }
done
for robot in "${src}"/deploy/robots/*.urdf; do
  cmp -s "${robot}" "${prefix}/share/teleop/robots/$(basename "${robot}")" || fail "$(basename "${robot}") not installed"
done
ok "the shipped URDFs in share/teleop/robots; the installed arm configs find them (teleop-arm check passes)"

# The consumer sees only the prefix: no path into the source or build tree.
cmake -S "${src}/deploy/examples/custom_backend" -B "${work}/example" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="${prefix}" -DCMAKE_EXPORT_COMPILE_COMMANDS=ON >"${work}/example-configure.log" 2>&1 ||
  { cat "${work}/example-configure.log"; fail "find_package(teleop) against the installed tree"; }
ok "find_package(teleop) finds ${prefix}/lib/cmake/teleop"
cmake --build "${work}/example" >"${work}/example-build.log" 2>&1 ||
  { cat "${work}/example-build.log"; fail "building the example against the installed tree"; }
grep -q -- "-I${prefix}/include\|-isystem ${prefix}/include" "${work}/example/compile_commands.json" ||
  fail "the example does not compile against ${prefix}/include"
# Every include directory of the example is the prefix or a system directory: nothing from the source tree.
while read -r dir; do
  case "${dir}" in
    "${prefix}"/* | /usr/include | /usr/include/*) ;;
    *) fail "the example includes ${dir}, which is not in the installed tree" ;;
  esac
done < <(grep -o -- '\(-I\|-isystem \)[^ "]*' "${work}/example/compile_commands.json" | sed 's/^-I//; s/^-isystem //' | sort -u)
ok "the example compiles against ${prefix}/include only"
out=$("${work}/example/custom_backend") || { echo "${out}"; fail "the example backend did not settle at 10 mm"; }
echo "${out}"
grep -q "registered backends: .*example-spring" <<<"${out}" && grep -q "registered backends: .*loopback" <<<"${out}" ||
  fail "example-spring is not registered beside loopback"
grep -q "x = 10.0000 mm" <<<"${out}" || fail "the example backend did not reach 10 mm"
ok "the out-of-tree backend registers, is created by name through MakeDevice and runs"
# The real path: spring-master (the example's own teleop-master through ProcessMain) paired with the installed
# teleop-slave.
/usr/bin/python3 "${src}/tests/deploy/custom_rig_pair.py" --master "${work}/example/spring-master" \
  --slave "${prefix}/bin/teleop-slave" --configs "${src}/deploy/examples/custom_backend" --workdir "${work}/pair" ||
  fail "the out-of-tree rig as a process pair"
ok "the out-of-tree rig runs as a process pair with teleop-slave"
# Every exported target resolves in a consumer: its dependencies are found by teleopConfig.cmake (a target that
# names, say, CLI11::CLI11 without a find_dependency fails here at generate time).
# Device backends (teleop::device_<name>) are reached through teleop::devices, which links them whole-archive; CMake
# refuses one link item both plain and whole-archive, so they are not listed on their own.
targets=$(grep -o 'add_library(teleop::[a-z_]*' "${prefix}/lib/cmake/teleop/teleopTargets.cmake" | sed 's/add_library(//' |
  grep -v '^teleop::device_' | sort -u)
mkdir -p "${work}/all-targets"
cat >"${work}/all-targets/CMakeLists.txt" <<CMAKE
cmake_minimum_required(VERSION 3.25)
project(teleop_all_targets LANGUAGES CXX)
find_package(teleop REQUIRED)
file(WRITE \${CMAKE_BINARY_DIR}/main.cpp "int main() { return 0; }\\n")
add_executable(all_targets \${CMAKE_BINARY_DIR}/main.cpp)
target_link_libraries(all_targets PRIVATE $(echo ${targets}))
CMAKE
cmake -S "${work}/all-targets" -B "${work}/all-targets/build" -G Ninja -DCMAKE_PREFIX_PATH="${prefix}" \
      >"${work}/all-targets.log" 2>&1 || { cat "${work}/all-targets.log"; fail "an exported target does not resolve"; }
ok "all $(wc -w <<<"${targets}") exported targets resolve in a consumer: $(echo ${targets})"
echo PASSED
