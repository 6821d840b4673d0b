#!/usr/bin/env bash
# libFuzzer harnesses for every decoder (tests/fuzz/, docs/security.md "Fuzzing"). They are targets of the sanitized
# build (the `debug` preset, build-debug/: clang, ASan + UBSan and the fuzzer's coverage instrumentation on every
# source), linked against the same library targets as the tests; the binaries land in build-debug/fuzz/.
#
#   deploy/fuzz.sh                      build, then run every harness for 60 s (the "run them longer" command)
#   deploy/fuzz.sh --time 600 --only can_cycle -- -jobs=2 -workers=2    one harness, 10 min, libFuzzer options after --
#   deploy/fuzz.sh --build-only         build only
#   deploy/fuzz.sh --no-build --time 3 --only udp_sample                run one, briefly (ctest's fuzz.<harness>)
#   deploy/fuzz.sh --seeds              regenerate the committed seed corpus tests/fuzz/corpus/ from the encoders
#
# Inputs a run finds are kept in build-debug/fuzz/corpus/<harness>/ (the committed seeds in tests/fuzz/corpus/ are
# only read); a crash is saved as build-debug/fuzz/artifacts/<harness>-crash-* and makes the script fail. Reproduce
# one with build-debug/fuzz/fuzz_<harness> FILE.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DEBUG_BUILD="${ROOT}/build-debug"
BUILD="${TELEOP_FUZZ_BUILD:-${DEBUG_BUILD}/fuzz}"
HARNESSES=(udp_sample secure_messages secure_session handshake can_cycle canopen_frames config)
TIME=60
BUILD_STEP=1
RUN_STEP=1
SEEDS=0
ONLY=()
EXTRA=()

while [[ $# -gt 0 ]]; do
  case "$1" in
    --time) TIME="$2"; shift 2 ;;
    --only) ONLY+=("$2"); shift 2 ;;
    --build-dir) BUILD="$2"; shift 2 ;;
    --build-only) RUN_STEP=0; shift ;;
    --no-build) BUILD_STEP=0; shift ;;
    --seeds) SEEDS=1; RUN_STEP=0; shift ;;
    --) shift; EXTRA=("$@"); break ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "fuzz.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ ${#ONLY[@]} -gt 0 ]] && HARNESSES=("${ONLY[@]}")
if ! [[ "${TIME}" =~ ^[0-9]+$ ]] || [[ "${TIME}" -lt 1 ]]; then
  echo "fuzz.sh: --time needs a whole number of seconds >= 1, got '${TIME}'" >&2
  exit 2
fi

if [[ ${BUILD_STEP} -eq 1 ]]; then
  if ! command -v clang++ >/dev/null; then
    echo "fuzz.sh: clang++ not found; install the Debian packages: apt-get install clang libclang-rt-14-dev" >&2
    exit 1
  fi
  # The sanitized build (CMakePresets.json `debug`: clang, ASan + UBSan, TELEOP_FUZZ=ON) builds the harnesses from
  # the same library targets as the tests; configure it once, then build only the harnesses (incremental).
  cd "${ROOT}"
  if [[ ! -f "${DEBUG_BUILD}/build.ninja" ]]; then
    cmake --preset debug >/dev/null
  fi
  targets=()
  for h in "${HARNESSES[@]}"; do targets+=("fuzz_$h"); done
  [[ ${SEEDS} -eq 1 ]] && targets+=(make_seeds)
  cmake --build "${DEBUG_BUILD}" --parallel "${TELEOP_FUZZ_JOBS:-$(nproc)}" --target "${targets[@]}"
fi

if [[ ${SEEDS} -eq 1 ]]; then
  "${BUILD}/make_seeds" "${ROOT}/tests/fuzz/corpus"
  echo "[fuzz] seed corpus written to tests/fuzz/corpus/"
fi

[[ ${RUN_STEP} -eq 1 ]] || exit 0

export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
status=0
for h in "${HARNESSES[@]}"; do
  bin="${BUILD}/fuzz_$h"
  if [[ ! -x "${bin}" ]]; then
    echo "fuzz.sh: ${bin} not built (run deploy/fuzz.sh --build-only)" >&2
    exit 1
  fi
  mkdir -p "${BUILD}/corpus/$h" "${BUILD}/artifacts"
  log="${BUILD}/fuzz_$h.log"
  echo "[fuzz] $h: ${TIME} s"
  if "${bin}" -max_total_time="${TIME}" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="${BUILD}/artifacts/$h-" "${EXTRA[@]}" \
       "${BUILD}/corpus/$h" "${ROOT}/tests/fuzz/corpus/$h" > "${log}" 2>&1; then
    grep -E "stat::number_of_executed_units|stat::new_units_added" "${log}" | sed "s/^/[fuzz] $h: /" || true
  else
    echo "[fuzz] $h FAILED; log: ${log}; inputs: ${BUILD}/artifacts/$h-*" >&2
    tail -n 40 "${log}" >&2
    status=1
  fi
done
exit ${status}
