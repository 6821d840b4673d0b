#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian 12 machine: installs what is missing, builds, checks formatting,
# runs every test with ctest (unit, closed loop, two-process integration, real-kernel CAN under qemu).
# In CI (CI=true) or with TELEOP_CHECK_TIDY=1 it also runs clang-tidy (about 3 minutes on 2 cores).
# Extra arguments go to ctest (e.g. ./deploy/test.sh -R law).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build
cmake --build "${TELEOP_BUILD}" --target check-format
if [[ "${CI:-}" == "true" || "${TELEOP_CHECK_TIDY:-0}" == "1" ]]; then
  cmake --build "${TELEOP_BUILD}" --target check-tidy
fi
cd "${TELEOP_BUILD}"
ctest --output-on-failure --parallel "$(nproc)" --timeout 600 "$@"
