#!/usr/bin/env bash
# Runs the whole test suite on a fresh Debian 12 machine: installs what is missing, builds, checks formatting,
# runs every test with ctest (unit, closed loop, two-process integration, real-kernel CAN under qemu).
# Then it builds the GoogleTest executables and the libFuzzer harnesses again with clang, ASan and UBSan (the `debug`
# preset, build-debug/) and runs them (TELEOP_SANITIZE=0 skips this pass). In CI (CI=true) or with TELEOP_CHECK_TIDY=1 it also runs clang-tidy.
# Extra arguments go to ctest (e.g. ./deploy/test.sh -R law).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build
cmake --build "${TELEOP_BUILD}" --target check-format
if [[ "${CI:-}" == "true" || "${TELEOP_CHECK_TIDY:-0}" == "1" ]]; then
  cmake --build "${TELEOP_BUILD}" --target check-tidy
fi
# A failed test's output lands mid-log; teleop::ctest prints the lines that say why once more at the end.
teleop::ctest "${TELEOP_BUILD}" --output-on-failure --parallel "$(nproc)" --timeout 600 "$@"

# Sanitizer pass: the `debug` preset (clang, AddressSanitizer + UndefinedBehaviorSanitizer, -g1 -O1, the fuzzer's
# coverage instrumentation) builds every GoogleTest executable (unit, closed-loop and node tests) and the fuzz harnesses
# (target teleop_unit_tests) into build-debug/ and runs them (`ctest -L unit`: the harnesses 3 s each), after the release suite has finished, never beside it: timing-sensitive tests would be starved.
# On by default and in CI; TELEOP_SANITIZE=0 skips it. Cost on the 2-core CI machine: docs/testing.md, "Test time".
if [[ "${TELEOP_SANITIZE:-1}" != "0" ]]; then
  teleop::build_sanitized
  export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1}"
  export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
  teleop::ctest "${TELEOP_BUILD_SANITIZED}" --output-on-failure --parallel "$(nproc)" --timeout 900 -L unit "$@"
fi
