#!/usr/bin/env bash
# Shared by deploy/demo.sh and deploy/test.sh: install missing Debian packages, configure and build.
set -euo pipefail

TELEOP_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
TELEOP_BUILD="${TELEOP_BUILD:-${TELEOP_ROOT}/build}"
TELEOP_BUILD_SANITIZED="${TELEOP_BUILD_SANITIZED:-${TELEOP_ROOT}/build-debug}"

# Debian 12 packages the build, the demo and the tests need. One list, so both commands agree.
TELEOP_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libboost-dev libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev libsodium-dev libmodbus-dev
  # arms (docs/arms.md): URDF parsing and the kinematics and dynamics
  liburdfdom-dev liborocos-kdl-dev
  clang-format clang-tidy clang libclang-rt-14-dev lld
  gnuplot-nox python3
  iproute2 can-utils
  python3-pymodbus python3-serial python3-serial-asyncio mbpoll socat
  qemu-system-x86 busybox-static cpio kmod
  # deployment (docs/deployment.md): teleop-plot, the Wireshark dissector test, the unit check, the .deb inspection
  python3-matplotlib
  tshark
  systemd
  dpkg-dev
  cyclonedds-dev cyclonedds-tools
  # teleop-supervise --http (docs/dds.md, "The dashboard"): dygraphs for the page; its test drives headless Chromium
  libjs-dygraphs chromium chromium-driver python3-selenium
  # deploy/bench.sh (docs/performance.md): cyclictest beside the loop, the NumPy/SciPy analysis reference
  rt-tests python3-numpy python3-scipy
)

teleop::missing_packages() {
  local missing=() p
  for p in "$@"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  echo "${missing[@]:-}"
}

# Installs what is missing: with apt-get as root, otherwise prints the exact command and fails.
teleop::ensure_packages() {
  local missing
  missing=$(teleop::missing_packages "$@")
  [[ -z "${missing// /}" ]] && return 0
  if [[ $(id -u) -eq 0 ]]; then
    echo "[teleop] installing missing Debian packages: ${missing}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # shellcheck disable=SC2086
    apt-get install -y -qq --no-install-recommends ${missing} >/dev/null
  else
    echo "[teleop] missing Debian packages. Install them with:" >&2
    echo "  sudo apt-get install -y ${missing}" >&2
    exit 1
  fi
}

# Configures (once) and builds the release preset into build/. Quick when nothing changed.
teleop::build() {
  cd "${TELEOP_ROOT}"
  if [[ ! -f "${TELEOP_BUILD}/build.ninja" ]]; then
    cmake --preset release >/dev/null
  fi
  cmake --build "${TELEOP_BUILD}" --parallel "$(nproc)" "$@"
}

# Configures (once) the `debug` preset (clang, ASan + UBSan) into build-debug/ and builds only the GoogleTest
# executables. A build-debug/ configured earlier with another compiler (the preset used GCC before) is configured
# afresh.
teleop::build_sanitized() {
  cd "${TELEOP_ROOT}"
  if [[ ! -f "${TELEOP_BUILD_SANITIZED}/build.ninja" ]]; then
    cmake --preset debug >/dev/null
  elif ! grep -q '^CMAKE_CXX_COMPILER:[A-Z]*=.*clang++' "${TELEOP_BUILD_SANITIZED}/CMakeCache.txt"; then
    cmake --preset debug --fresh >/dev/null
  fi
  cmake --build "${TELEOP_BUILD_SANITIZED}" --parallel "$(nproc)" --target teleop_unit_tests
}

# Runs ctest in a build directory with the given arguments. When a test fails, ctest's output has it mid-log (where
# the test ended); deploy/lib/failure_digest.py then prints, last, the lines that say why each failed test failed.
# When every failed test is timing-sensitive (it holds the two_process_cpu or qemu_guest lock, or runs RUN_SERIAL:
# deploy/lib/timing_sensitive.py), those tests run once more, one at a time, and the run passes only if each passes
# there; the first failure stays in the log above, and the tests that needed the second run are named last
# (docs/testing.md, "A second run for timing-sensitive tests"). TELEOP_SECOND_RUN=0 turns it off.
teleop::ctest() {
  local dir="$1"
  shift
  local rc=0
  # A first run (no measured test times: a fresh clone, CI) starts the locked chains first.
  python3 "${TELEOP_ROOT}/deploy/lib/timing_sensitive.py" --seed-costs "${dir}" || true
  (cd "${dir}" && ctest "$@") || rc=$?
  if [[ ${rc} -ne 0 ]]; then
    python3 "${TELEOP_ROOT}/deploy/lib/failure_digest.py" "${dir}" || true
    if [[ "${TELEOP_SECOND_RUN:-1}" != "0" ]] && python3 "${TELEOP_ROOT}/deploy/lib/timing_sensitive.py" "${dir}"; then
      local first
      first="$(cut -d: -f2 "${dir}/Testing/Temporary/LastTestsFailed.log" | tr '\n' ' ')"
      echo "==== a second run, one at a time, of the timing-sensitive tests that failed: ${first}===="
      rc=0
      (cd "${dir}" && ctest --rerun-failed --output-on-failure --parallel 1 --timeout 600) || rc=$?
      if [[ ${rc} -eq 0 ]]; then
        echo "==== passed on the second run, alone (failed the first time beside other tests): ${first}===="
      else
        python3 "${TELEOP_ROOT}/deploy/lib/failure_digest.py" "${dir}" || true
      fi
    fi
  fi
  return "${rc}"
}
