#!/usr/bin/env bash
# clang-tidy (the repo's .clang-tidy, warnings are errors) over every library, app and process source in the build's
# compile_commands.json, in parallel. Usage: deploy/lib/check_tidy.sh BUILD_DIR
set -euo pipefail
build="${1:?build directory}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
runner="$(command -v run-clang-tidy-14 || command -v run-clang-tidy)"
tidy="$(command -v clang-tidy-14 || command -v clang-tidy)"
log="${build}/clang-tidy.log"
if "${runner}" -p "${build}" -quiet -j "$(nproc)" -clang-tidy-binary "${tidy}" \
     -extra-arg=-Wno-unknown-warning-option "${root}/(proto|common|master|slave)/.*\.cpp$" > "${log}" 2>&1; then
  echo "clang-tidy: clean"
else
  grep -E "(warning|error):" "${log}" | sort -u || tail -n 40 "${log}"
  echo "clang-tidy: findings above (full log: ${log})" >&2
  exit 1
fi
