#!/usr/bin/env bash
# clang-tidy (the repo's .clang-tidy, warnings are errors) over the library, app and process sources in the build's
# compile_commands.json, in parallel. Usage: deploy/lib/check_tidy.sh BUILD_DIR
#
# Scope: by default only the sources whose inputs (the source or any project header it includes, from ninja's
# dependency log) changed since the commit in .ci/tidy-baseline, the last commit on which the whole tree was checked
# clean (deploy/lib/tidy_scope.py says how it decides). TELEOP_TIDY_SCOPE=full checks every source; after a clean full
# run, write that commit into .ci/tidy-baseline so that later runs check only what changed since.
set -euo pipefail
build="$(cd "${1:?build directory}" && pwd)"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
tidy="$(command -v clang-tidy-14 || command -v clang-tidy)"
log="${build}/clang-tidy.log"
list="${build}/clang-tidy.files"
baseline_file="${root}/.ci/tidy-baseline"

if [[ "${TELEOP_TIDY_SCOPE:-changed}" != "full" && -s "${baseline_file}" ]]; then
  base="$(tr -d '[:space:]' < "${baseline_file}")"
  python3 "${root}/deploy/lib/tidy_scope.py" "${build}" "${base}" > "${list}"
else
  python3 - "${build}" > "${list}" <<'PY'
import json, os, re, sys
build = sys.argv[1]
lib = re.compile(r"/(proto|common|master|slave)/.*\.cpp$")
files = {os.path.normpath(os.path.join(e["directory"], e["file"])) for e in json.load(open(os.path.join(build, "compile_commands.json")))}
print("\n".join(sorted(f for f in files if lib.search(f))))
PY
  echo "clang-tidy: full check, $(wc -l < "${list}") sources"
fi
sed -i '/^[[:space:]]*$/d' "${list}"  # an empty scope is an empty file, not one blank line
if [[ ! -s "${list}" ]]; then
  echo "clang-tidy: clean (no library source reads a file changed since $(head -c 12 "${baseline_file}"), the last full check)"
  exit 0
fi
if xargs -a "${list}" -P "$(nproc)" -n 4 "${tidy}" -p "${build}" --quiet \
     --extra-arg=-Wno-unknown-warning-option > "${log}" 2>&1; then
  echo "clang-tidy: clean ($(wc -l < "${list}") sources)"
else
  grep -E "(warning|error):" "${log}" | sort -u || tail -n 40 "${log}"
  echo "clang-tidy: findings above (full log: ${log})" >&2
  exit 1
fi
