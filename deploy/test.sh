#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian 12 machine: installs what is missing, builds, checks formatting,
# runs every test with ctest (unit, closed loop, two-process integration, real-kernel CAN under qemu).
# Extra arguments go to ctest (e.g. ./deploy/test.sh -R law).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build
cmake --build "${TELEOP_BUILD}" --target check-format
cd "${TELEOP_BUILD}"
ctest --output-on-failure --parallel "$(nproc)" --timeout 600 "$@"
