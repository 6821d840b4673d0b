#!/usr/bin/env bash
# deploy/bench.sh: every performance figure of docs/performance.md in one bounded run (a few minutes).
#
#   deploy/bench.sh                 # full run: writes docs/performance.md and docs/performance.json
#   deploy/bench.sh --smoke --out DIR   # seconds: every step once, tiny durations, writes DIR/performance.{md,json}
#   deploy/bench.sh --scale [--quick]   # the scale sections only (DOF sweep, pairs per host, interleaved jitter):
#                                       # about 11 min (--quick: 3 min, provisional); deploy/bench/scale.sh says more
#
# Side by side in the same run: loop timing of both processes at 1, 2, 4, 8 kHz, free-running and phase-locked
# (sync.mode triggered), and of the loop alone (teleop-loop-bench) beside cyclictest at the same interval and
# priority, with and without real-time settings; the round trip and the data age from the processes' summaries
# beside a plain C UDP ping-pong of the same size; control step, encode/decode, link and CAN benchmarks;
# allocations per cycle of a process run (LD_PRELOAD counter); analysis time beside an independent NumPy/SciPy
# implementation; the cost of writing every cycle to CSV. Real-time settings = SCHED_FIFO 80, mlockall, one CPU per
# process and /dev/cpu_dma_latency held at 0 (realtime.cpu_dma_latency_us: 0 in the processes' configs; the loop
# bench and cyclictest hold it themselves).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

if [[ "${1:-}" == --scale ]]; then
  shift
  exec "$(dirname "${BASH_SOURCE[0]}")/bench/scale.sh" "$@"
fi

smoke=0
out_dir="${TELEOP_ROOT}/docs"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --smoke) smoke=1 ;;
    --out) out_dir="$2"; shift ;;
    *) echo "usage: deploy/bench.sh [--smoke] [--out DIR] | deploy/bench.sh --scale [--quick] [--out DIR]" >&2; exit 1 ;;
  esac
  shift
done
command_line="deploy/bench.sh${*:+ $*}"
[[ ${smoke} -eq 1 ]] && command_line="deploy/bench.sh --smoke"

if [[ "${TELEOP_BENCH_NO_BUILD:-0}" != 1 ]]; then
  teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
  teleop::build --target teleop-master teleop-slave teleop-analyze teleop-udp-pingpong teleop-loop-bench \
    teleop-alloc-count control_benchmark proto_codec_benchmark transport_link_benchmark analysis_benchmark \
    teleop_keygen
  teleop::build --target can_link_benchmark 2>/dev/null || true
fi
bin="${TELEOP_BUILD}/bin"
work="$(mktemp -d "${TMPDIR:-/tmp}/teleop-bench.XXXXXX")"
raw="${work}/raw"
mkdir -p "${raw}"
# The configs authenticate the link (link.security.mode psk, key_file teleop.key beside them): one key for the run.
"${bin}/teleop-keygen" "${work}/teleop.key" > /dev/null
pids=()
cleanup() {
  for p in "${pids[@]:-}"; do [[ -n "$p" ]] && kill "$p" 2>/dev/null || true; done
  rm -rf "${work}"
}
trap cleanup EXIT

if [[ ${smoke} -eq 1 ]]; then
  run_s=1; slave_extra_s=1; cyclic_s=1; loop_s=0.5; pingpong_count=500; bench_time=0.01; rates=(1000); modes=(off)
else
  run_s=2; slave_extra_s=3; cyclic_s=2; loop_s=2; pingpong_count=20000; bench_time=0.2; rates=(1000 2000 4000 8000)
  modes=(off rt)
fi
syncs=(free triggered)
spin_us=100  # the triggered-spin runs (real-time only): poll the socket from 100 us before the master's sample is due
ncpu=$(nproc)
cpu_master=0; cpu_slave=$(( ncpu > 1 ? 1 : 0 ))
can_rt=0
if [[ $(id -u) -eq 0 ]]; then can_rt=1; fi
log() { echo "[bench] $*" >&2; }

# --- machine -----------------------------------------------------------------------------------------------------
{
  echo "{"
  echo "  \"host\": \"$(cat /proc/sys/kernel/hostname)\","
  echo "  \"kernel\": \"$(uname -srvm | sed 's/"/\\"/g')\","
  echo "  \"cpu\": \"$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//;s/"/\\"/g')\","
  echo "  \"cpus\": ${ncpu},"
  echo "  \"preempt_rt\": $([[ -e /sys/kernel/realtime ]] && echo true || echo false),"
  echo "  \"root\": $([[ $(id -u) -eq 0 ]] && echo true || echo false),"
  echo "  \"loadavg_start\": \"$(cut -d' ' -f1-3 /proc/loadavg)\","
  echo "  \"date_utc\": \"$(date -u +%Y-%m-%dT%H:%M:%SZ)\","
  echo "  \"git\": \"$(git -C "${TELEOP_ROOT}" rev-parse --short HEAD 2>/dev/null || echo unknown)\","
  echo "  \"command\": \"${command_line}\","
  echo "  \"smoke\": $([[ ${smoke} -eq 1 ]] && echo true || echo false)"
  echo "}"
} > "${raw}/machine.json"

# --- processes: configs per rate and mode ------------------------------------------------------------------------
# Ports of their own (47601/47602) so a demo running beside does not collide.
make_config() {  # role rate mode [sync] > file
  local role=$1 rate=$2 mode=$3 sync=${4:-free} src="${TELEOP_ROOT}/deploy/configs/$1.yaml" fifo=0 cpu=-1 lock=false
  local dma=-1
  if [[ ${mode} == rt ]]; then
    fifo=80; lock=true; dma=0
    cpu=$([[ ${role} == master ]] && echo ${cpu_master} || echo ${cpu_slave})
  fi
  sed -e "s/^rate_hz: .*/rate_hz: ${rate}/" -e "s/fifo_priority: .*/fifo_priority: ${fifo}/" \
    -e "s/^  cpu: .*/  cpu: ${cpu}/" -e "s/lock_memory: .*/lock_memory: ${lock}\n  cpu_dma_latency_us: ${dma}/" \
    -e 's/127.0.0.1:47001/127.0.0.1:47601/' -e 's/127.0.0.1:47002/127.0.0.1:47602/' "${src}"
  if [[ ${sync} == triggered-spin ]]; then
    echo "sync: {mode: triggered, spin_us: ${spin_us}}"
  else
    echo "sync: {mode: ${sync}}"
  fi
}

run_pair() {  # rate mode tag sync [extra master args...]
  local rate=$1 mode=$2 tag=$3 sync=$4
  shift 4
  make_config master "${rate}" "${mode}" "${sync}" > "${work}/master-${tag}.yaml"
  make_config slave "${rate}" "${mode}" "${sync}" > "${work}/slave-${tag}.yaml"
  "${bin}/teleop-slave" --config "${work}/slave-${tag}.yaml" --duration "$(( run_s + slave_extra_s ))" \
    --summary-json "${raw}/slave-${tag}.json" > "${work}/slave-${tag}.log" 2>&1 &
  local slave_pid=$!
  pids+=("${slave_pid}")
  sleep 0.5
  "${bin}/teleop-master" --config "${work}/master-${tag}.yaml" --duration "${run_s}" \
    --summary-json "${raw}/master-${tag}.json" "$@" > "${work}/master-${tag}.log" 2>&1 || log "master ${tag} failed"
  wait "${slave_pid}" || true
}

cyclictest_run() {  # interval_us mode tag
  local interval=$1 mode=$2 tag=$3 args
  if ! command -v cyclictest >/dev/null; then echo '{"missing": true}' > "${raw}/cyclictest-${tag}.json"; return; fi
  local loops=$(( cyclic_s * 1000000 / interval ))
  if [[ ${mode} == rt ]]; then
    args=(-p 80 -m -a "${cpu_slave}")
  else
    args=(--laptop -p 0)
  fi
  cyclictest -q -t1 -i "${interval}" -l "${loops}" -h 10000 "${args[@]}" > "${work}/cyclictest-${tag}.txt" 2>&1 || true
  /usr/bin/python3 "${TELEOP_ROOT}/deploy/bench/cyclictest_json.py" "${work}/cyclictest-${tag}.txt" "${interval}" "${mode}" \
    > "${raw}/cyclictest-${tag}.json"
}

log "loop timing of the processes (${rates[*]} Hz; modes ${modes[*]}; ${syncs[*]}) and cyclictest beside"
for mode in "${modes[@]}"; do
  if [[ ${mode} == rt && ${can_rt} -eq 0 ]]; then log "not root: skipping the real-time runs"; continue; fi
  echo "{\"mode\": \"${mode}\", \"loadavg\": \"$(cut -d' ' -f1-3 /proc/loadavg)\"}" > "${raw}/mode-${mode}.json"
  for rate in "${rates[@]}"; do
    mode_syncs=("${syncs[@]}")
    [[ ${mode} == rt ]] && mode_syncs+=(triggered-spin)
    for sync in "${mode_syncs[@]}"; do
      log "  ${rate} Hz ${mode} ${sync}"
      tag="${rate}-${mode}"
      [[ ${sync} != free ]] && tag="${rate}-${mode}-${sync}"
      run_pair "${rate}" "${mode}" "${tag}" "${sync}"
    done
  done
  rates_with_8k=("${rates[@]}")
  [[ " ${rates[*]} " == *" 8000 "* ]] || rates_with_8k+=(8000)
  for rate in "${rates_with_8k[@]}"; do
    cyclictest_run $(( 1000000 / rate )) "${mode}" "${rate}-${mode}"
  done
  # The loop alone (an empty body), beside the processes.
  for rate in "${rates_with_8k[@]}"; do
    if [[ ${mode} == rt ]]; then
      "${bin}/teleop-loop-bench" --rate "${rate}" --duration "${loop_s}" --fifo 80 --cpu "${cpu_slave}" --lock \
        --dma-latency-us 0 > "${raw}/loop-${rate}-${mode}.json" || true
    else
      "${bin}/teleop-loop-bench" --rate "${rate}" --duration "${loop_s}" > "${raw}/loop-${rate}-${mode}.json" || true
    fi
  done
done

log "cost of writing every cycle to CSV (1 kHz, no real-time settings)"
run_pair 1000 off "1000-off-csv" free --telemetry-csv "${work}/master.csv"

log "allocations per cycle of a process run (two durations, LD_PRELOAD counter)"
alloc_lib="${TELEOP_BUILD}/lib/libteleop-alloc-count.so"
if [[ -f "${alloc_lib}" ]]; then
  for d in 1 2; do
    make_config master 1000 off > "${work}/master-alloc.yaml"
    make_config slave 1000 off > "${work}/slave-alloc.yaml"
    TELEOP_ALLOC_COUNT_FILE="${raw}/alloc-slave-${d}.txt" LD_PRELOAD="${alloc_lib}" "${bin}/teleop-slave" \
      --config "${work}/slave-alloc.yaml" --duration "$(( d + slave_extra_s ))" --summary-json "${raw}/alloc-slave-${d}.json" \
      > /dev/null 2>&1 &
    slave_pid=$!
    pids+=("${slave_pid}")
    sleep 0.5
    TELEOP_ALLOC_COUNT_FILE="${raw}/alloc-master-${d}.txt" LD_PRELOAD="${alloc_lib}" "${bin}/teleop-master" \
      --config "${work}/master-alloc.yaml" --duration "${d}" --summary-json "${raw}/alloc-master-${d}.json" \
      > /dev/null 2>&1 || true
    wait "${slave_pid}" || true
  done
fi

log "UDP ping-pong floor (64 B = 1-DOF sample, 184 B = 6-DOF sample)"
for bytes in 64 184; do
  "${bin}/teleop-udp-pingpong" --bytes "${bytes}" --count "${pingpong_count}" > "${raw}/pingpong-${bytes}-off.json"
  if [[ ${can_rt} -eq 1 && ${smoke} -eq 0 ]]; then
    "${bin}/teleop-udp-pingpong" --bytes "${bytes}" --count "${pingpong_count}" --fifo 80 \
      --cpu "${cpu_master},${cpu_slave}" > "${raw}/pingpong-${bytes}-rt.json"
  fi
done

log "micro-benchmarks (Google Benchmark, JSON)"
for b in control_benchmark proto_codec_benchmark transport_link_benchmark; do
  "${bin}/${b}" --benchmark_format=json --benchmark_min_time="${bench_time}" > "${raw}/${b}.json" 2>/dev/null || true
done
if [[ -x "${bin}/can_link_benchmark" ]]; then
  "${bin}/can_link_benchmark" --benchmark_format=json --benchmark_min_time="${bench_time}" \
    > "${work}/can_link_benchmark.out" 2>/dev/null || true
  # The bus-load table comes first on stdout, then the JSON.
  awk 'found || /^\{/ {found = 1; print}' "${work}/can_link_benchmark.out" > "${raw}/can_link_benchmark.json"
  awk '/^\{/ {exit} {print}' "${work}/can_link_benchmark.out" > "${raw}/can_budget.txt"
fi

log "analysis: C++ against NumPy/SciPy"
if [[ ${smoke} -eq 1 ]]; then
  analysis_filter='BM_WorstCaseLimit512/slave:1/threads:1/delay:0'
else
  analysis_filter='BM_WorstCaseLimit512|BM_Fig7Curve10Rates/threads:1'
fi
"${bin}/analysis_benchmark" --benchmark_format=json --benchmark_min_time="${bench_time}" \
  --benchmark_filter="${analysis_filter}" > "${raw}/analysis_benchmark.json" 2>/dev/null || true
{
  echo "["
  first=1
  fractions=(0 0.05 0.5 1)
  [[ ${smoke} -eq 1 ]] && fractions=(0)
  for side in slave master; do
    for f in "${fractions[@]}"; do
      [[ ${smoke} -eq 1 && ${side} == master ]] && continue
      [[ ${first} -eq 0 ]] && echo ","
      first=0
      "${bin}/teleop-analyze" max-stiffness --side "${side}" --kp 600 --kd 2 --rate 1000 --threads 1 \
        --velocity-filter-hz 0 --peer-delay-samples 0 --peer-delay-fraction "${f}" --json
    done
  done
  if [[ ${smoke} -eq 0 ]]; then
    echo ","
    "${bin}/teleop-analyze" max-stiffness --side slave --kp 600 --kd 2 --rate 1000 --threads 1 \
      --velocity-filter-hz 0 --peer-delay-samples 1 --json
    # A triggered pair: the master sees the slave's reply one sample late, the slave the master's sample late by the
    # data age measured above (p99 of the 1 kHz triggered slave, real-time run if there was one) and by the
    # start-up check's default assumption (100 us).
    measured=$(/usr/bin/python3 - "${raw}/slave-1000-rt-triggered.json" "${raw}/slave-1000-off-triggered.json" <<'PY'
import json, sys
for path in sys.argv[1:]:
    try:
        age = json.load(open(path))["data_age_us"]
    except (OSError, ValueError, KeyError):
        continue
    if age.get("count"):
        print(f"{min(1.0, age['p99'] * 1e-3):.4f}")
        break
PY
)
    for f in 0.1 ${measured}; do
      echo ","
      "${bin}/teleop-analyze" max-stiffness --side slave --kp 600 --kd 2 --rate 1000 --threads 1 \
        --velocity-filter-hz 200 --peer-delay-samples 1 --slave-peer-delay-fraction "${f}" --json
    done
    # The shipped slave config (deploy/configs/slave.yaml) also filters the velocity at 200 Hz.
    for f in "${fractions[@]}"; do
      echo ","
      "${bin}/teleop-analyze" max-stiffness --side slave --kp 600 --kd 2 --rate 1000 --threads 1 \
        --velocity-filter-hz 200 --peer-delay-samples 0 --peer-delay-fraction "${f}" --json
    done
  fi
  echo "]"
} > "${raw}/analyze_limits.json"
reference_args=()
[[ ${smoke} -eq 1 ]] && reference_args=(--quick)
/usr/bin/python3 "${TELEOP_ROOT}/deploy/bench/analysis_reference.py" "${reference_args[@]}" > "${raw}/analysis_reference.json"

echo "{\"loadavg_end\": \"$(cut -d' ' -f1-3 /proc/loadavg)\"}" > "${raw}/machine_end.json"
mkdir -p "${out_dir}"
/usr/bin/python3 "${TELEOP_ROOT}/deploy/bench/report.py" "${raw}" "${out_dir}/performance.json" "${out_dir}/performance.md"
log "wrote ${out_dir}/performance.md and ${out_dir}/performance.json"
