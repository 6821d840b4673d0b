#!/usr/bin/env bash
# deploy/bench/scale.sh (run as `deploy/bench.sh --scale ...`): the scale sections of docs/performance.md.
#
#   deploy/bench.sh --scale                  # real mode, about 11 min on 2 CPUs: rewrites the marked scale region of
#                                            # docs/performance.md, docs/performance-scale.json, docs/performance/*.png
#   deploy/bench.sh --scale --quick          # every point with 1 s runs (about 3 min): the same files, marked provisional
#   deploy/bench.sh --scale --smoke --out D  # seconds: a few points, into D (the ctest deploy_bench_smoke)
#   options: --run-s S (seconds per run), --rounds N (interleaved jitter rounds), --out DIR
#
# 1. DOF sweep (1, 2, 3, 6, 7, 12) over UDP, classic CAN and CAN FD (the emulated bus, teleop-canbus), at 1 and 4 kHz,
#    with the real-time settings when root: compute per cycle, overruns, data age, wake-up jitter of both processes
#    (sync.mode triggered: the slave's cycle starts on the master's sample); datagram/frame bytes and bus load
#    (computed by can_link_benchmark); the start-up stability analysis time (from the processes' logs, and of a
#    slave whose axes all differ, so that no axis reuses another's analysis).
# 2. Pairs per host (1, 2, 4, 8 pairs of 1 DOF running at once) over the same three transports (one emulated bus per
#    pair), at 1 kHz with and without the real-time settings and at 4 kHz with them.
# 3. The 1 kHz jitter, interleaved: cyclictest, the loop alone (teleop-loop-bench) with the processes' timer slack
#    (1 ns) and with the kernel's default (50 µs), and the master of a pair, one after the other in rounds, at the same
#    settings and on the same CPU, at 1 kHz and 8 kHz (real-time) and 1 kHz (normal scheduling).
# 4. The compute of one cycle versus DOF (control_benchmark BM_CycleCompute, BM_LawStep; proto_codec_benchmark).
# Then deploy/bench/scale_report.py turns the raw files into the tables, the fitted models and the plots.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/../lib/common.sh"

level=real
out_dir="${TELEOP_ROOT}/docs"
run_s=""
rounds=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) level=quick ;;
    --smoke) level=smoke ;;
    --out) out_dir="$2"; shift ;;
    --run-s) run_s="$2"; shift ;;
    --rounds) rounds="$2"; shift ;;
    *) echo "usage: deploy/bench.sh --scale [--quick|--smoke] [--run-s S] [--rounds N] [--out DIR]" >&2; exit 1 ;;
  esac
  shift
done
case "${level}" in
  real) run_s=${run_s:-5}; rounds=${rounds:-4}; jitter_s=4; dofs=(1 2 3 6 7 12); pair_counts=(1 2 4 8)
        rates=(1000 4000); bench_time=0.2 ;;
  quick) run_s=${run_s:-1}; rounds=${rounds:-2}; jitter_s=1; dofs=(1 2 3 6 7 12); pair_counts=(1 2 4 8)
         rates=(1000 4000); bench_time=0.05 ;;
  smoke) run_s=${run_s:-0.5}; rounds=${rounds:-1}; jitter_s=0.3; dofs=(1 12); pair_counts=(2); rates=(1000)
         bench_time=0.01 ;;
esac
transports=(udp can can-fd)

if [[ "${TELEOP_BENCH_NO_BUILD:-0}" != 1 ]]; then
  teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
  teleop::build --target teleop-master teleop-slave teleop-canbus teleop-loop-bench teleop_keygen control_benchmark \
    proto_codec_benchmark can_link_benchmark
fi
bin="${TELEOP_BUILD}/bin"
work="$(mktemp -d "${TMPDIR:-/tmp}/teleop-scale.XXXXXX")"
raw="${work}/raw"
mkdir -p "${raw}"
"${bin}/teleop-keygen" "${work}/teleop.key" > /dev/null
pids=()
cleanup() {
  for p in "${pids[@]:-}"; do [[ -n "$p" ]] && kill "$p" 2>/dev/null || true; done
  rm -rf "${work}"
}
trap cleanup EXIT
# The processes write fault records (a peer lost at a run's end) into their working directory: the scratch one.
cd "${work}"
ncpu=$(nproc)
cpu_master=0; cpu_slave=$(( ncpu > 1 ? 1 : 0 ))
is_root=0
[[ $(id -u) -eq 0 ]] && is_root=1
rt_mode=off
[[ ${is_root} -eq 1 ]] && rt_mode=rt
log() { echo "[bench --scale] $*" >&2; }
started=$(date +%s)
# cpu0's idle states as name:usage pairs (does /dev/cpu_dma_latency 0 keep the CPU in POLL? the usage counts tell).
idle_states() {
  local st out=""
  for st in /sys/devices/system/cpu/cpu0/cpuidle/state*; do
    [[ -d ${st} ]] && out+="$(cat "${st}/name"):$(cat "${st}/usage") "
  done
  echo "${out% }"
}

{
  echo "{"
  echo "  \"host\": \"$(cat /proc/sys/kernel/hostname)\","
  echo "  \"kernel\": \"$(uname -srvm | sed 's/"/\\"/g')\","
  echo "  \"cpu\": \"$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//;s/"/\\"/g')\","
  echo "  \"cpus\": ${ncpu},"
  echo "  \"root\": $([[ ${is_root} -eq 1 ]] && echo true || echo false),"
  echo "  \"cpuidle_driver\": \"$(cat /sys/devices/system/cpu/cpuidle/current_driver 2>/dev/null || echo none)\","
  echo "  \"clocksource\": \"$(cat /sys/devices/system/clocksource/clocksource0/current_clocksource 2>/dev/null || echo unknown)\","
  echo "  \"guest_halt_poll_ns\": \"$(cat /sys/module/haltpoll/parameters/guest_halt_poll_ns 2>/dev/null || echo none)\","
  echo "  \"idle_states_start\": \"$(idle_states)\","
  echo "  \"loadavg_start\": \"$(cut -d' ' -f1-3 /proc/loadavg)\","
  echo "  \"date_utc\": \"$(date -u +%Y-%m-%dT%H:%M:%SZ)\","
  echo "  \"git\": \"$(git -C "${TELEOP_ROOT}" rev-parse --short HEAD 2>/dev/null || echo unknown)\","
  echo "  \"level\": \"${level}\", \"run_s\": ${run_s}, \"rounds\": ${rounds}, \"jitter_s\": ${jitter_s}"
  echo "}"
} > "${raw}/machine.json"

# --- configs -----------------------------------------------------------------------------------------------------
# make_config role transport rate mode dof pair_index [distinct_axes] > file
make_config() {
  local role=$1 transport=$2 rate=$3 mode=$4 dof=$5 n=$6 distinct=${7:-0}
  local src="${TELEOP_ROOT}/deploy/configs/${role}.yaml" fifo=0 cpu=-1 lock=false dma=-1 fd=false
  [[ ${transport} != udp ]] && src="${TELEOP_ROOT}/deploy/configs/${role}-can.yaml"
  [[ ${transport} == can-fd ]] && fd=true
  if [[ ${mode} == rt ]]; then
    fifo=80; lock=true; dma=0
    cpu=$([[ ${role} == master ]] && echo ${cpu_master} || echo ${cpu_slave})
  fi
  local kp="600"
  if [[ ${distinct} -eq 1 ]]; then  # every axis its own gain: the start-up check analyses each axis
    kp="[$(seq -s, 600 -5 $(( 600 - 5 * (dof - 1) )))]"
  fi
  local m_port=$(( 47601 + 2 * n )) s_port=$(( 47602 + 2 * n )) bus_port=$(( 47700 + n ))
  sed -e "s/^dof: .*/dof: ${dof}/" -e "s/^rate_hz: .*/rate_hz: ${rate}/" \
    -e "s/fifo_priority: .*/fifo_priority: ${fifo}/" -e "s/^  cpu: .*/  cpu: ${cpu}/" \
    -e "s/lock_memory: .*/lock_memory: ${lock}\n  cpu_dma_latency_us: ${dma}/" \
    -e "s/127.0.0.1:47001/127.0.0.1:${m_port}/" -e "s/127.0.0.1:47002/127.0.0.1:${s_port}/" \
    -e "s/127.0.0.1:47300/127.0.0.1:${bus_port}/" -e "s/^    fd: false .*/    fd: ${fd}/" \
    -e "s/^  kp_N_per_m: .*/  kp_N_per_m: ${kp}/" "${src}"
  echo "sync: {mode: triggered}"
}

# run_pairs tag transport rate mode dof count: `count` pairs at once; summaries raw/<tag>-<i>-<role>.json, the logs'
# stability line and exit status in raw/<tag>-<i>-run.json.
run_pairs() {
  local tag=$1 transport=$2 rate=$3 mode=$4 dof=$5 count=$6 i
  local slave_pids=() master_pids=() bus_pids=()
  for (( i = 0; i < count; i++ )); do
    make_config master "${transport}" "${rate}" "${mode}" "${dof}" "${i}" > "${work}/master-${tag}-${i}.yaml"
    make_config slave "${transport}" "${rate}" "${mode}" "${dof}" "${i}" > "${work}/slave-${tag}-${i}.yaml"
    if [[ ${transport} != udp ]]; then
      "${bin}/teleop-canbus" --port $(( 47700 + i )) --bitrate 1000000 --data-bitrate 5000000 \
        > "${work}/bus-${tag}-${i}.log" 2>&1 &
      bus_pids+=($!); pids+=($!)
    fi
  done
  [[ ${transport} != udp ]] && sleep 0.3
  for (( i = 0; i < count; i++ )); do
    "${bin}/teleop-slave" --config "${work}/slave-${tag}-${i}.yaml" --duration "$(awk "BEGIN {print ${run_s} + 1.5}")" \
      --summary-json "${raw}/${tag}-${i}-slave.json" > "${work}/slave-${tag}-${i}.log" 2>&1 &
    slave_pids+=($!); pids+=($!)
  done
  sleep 0.5
  for (( i = 0; i < count; i++ )); do
    "${bin}/teleop-master" --config "${work}/master-${tag}-${i}.yaml" --duration "${run_s}" \
      --summary-json "${raw}/${tag}-${i}-master.json" > "${work}/master-${tag}-${i}.log" 2>&1 &
    master_pids+=($!); pids+=($!)
  done
  local statuses=()
  for (( i = 0; i < count; i++ )); do
    local ms=0 ss=0
    wait "${master_pids[$i]}" || ms=$?
    wait "${slave_pids[$i]}" || ss=$?
    statuses+=("${ms},${ss}")
  done
  for p in "${bus_pids[@]:-}"; do [[ -n "$p" ]] && kill "$p" 2>/dev/null && wait "$p" 2>/dev/null || true; done
  for (( i = 0; i < count; i++ )); do
    /usr/bin/python3 - "${work}/master-${tag}-${i}.log" "${work}/slave-${tag}-${i}.log" "${statuses[$i]}" \
      "${transport}" "${rate}" "${mode}" "${dof}" "${count}" > "${raw}/${tag}-${i}-run.json" <<'PY'
import json, re, sys
def scan(path):
    text = open(path, errors="replace").read()
    ms = None
    m = re.search(r"stability[^\n]*?; (\d+(?:\.\d+)?) ms", text)
    if m:
        ms = float(m.group(1))
    lines = text.splitlines()
    reason = next((l.strip() for l in lines if "[critical]" in l), None)
    if reason is None:
        reason = next((l.strip() for l in lines if "error" in l.lower()), None)
    return ms, reason[:600] if reason else None
(m_ms, m_reason), (s_ms, s_reason) = scan(sys.argv[1]), scan(sys.argv[2])
ms, ss = (int(x) for x in sys.argv[3].split(","))
print(json.dumps({"transport": sys.argv[4], "rate_hz": int(sys.argv[5]), "mode": sys.argv[6], "dof": int(sys.argv[7]),
                  "pairs": int(sys.argv[8]), "master_exit": ms, "slave_exit": ss, "analysis_ms_master": m_ms,
                  "analysis_ms_slave": s_ms, "refused": m_reason if ms else (s_reason if ss else None)}))
PY
  done
}

# --- 1. DOF sweep -------------------------------------------------------------------------------------------------
log "DOF sweep (${dofs[*]}) over ${transports[*]} at ${rates[*]} Hz, mode ${rt_mode}, ${run_s} s per run"
for transport in "${transports[@]}"; do
  for rate in "${rates[@]}"; do
    for dof in "${dofs[@]}"; do
      log "  ${transport} ${rate} Hz ${dof} DOF"
      run_pairs "dof-${transport}-${rate}-${dof}" "${transport}" "${rate}" "${rt_mode}" "${dof}" 1
    done
  done
done
# The start-up analysis when no axis can reuse another's (every axis its own gain): the slave alone, briefly.
for dof in "${dofs[@]}"; do
  make_config slave udp 1000 off "${dof}" 0 1 > "${work}/slave-analysis-${dof}.yaml"
  "${bin}/teleop-slave" --config "${work}/slave-analysis-${dof}.yaml" --duration 0.05 \
    > "${work}/slave-analysis-${dof}.log" 2>&1 || true
  /usr/bin/python3 - "${work}/slave-analysis-${dof}.log" "${dof}" > "${raw}/analysis-distinct-${dof}.json" <<'PY'
import json, re, sys
m = re.search(r"stability[^\n]*?; (\d+(?:\.\d+)?) ms", open(sys.argv[1], errors="replace").read())
print(json.dumps({"dof": int(sys.argv[2]), "analysis_ms": float(m.group(1)) if m else None}))
PY
done

# --- 2. pairs per host -------------------------------------------------------------------------------------------
pair_modes=("1000 off")
[[ ${is_root} -eq 1 ]] && pair_modes+=("1000 rt" "4000 rt")
[[ ${level} == smoke ]] && pair_modes=("1000 off")
log "pairs per host (${pair_counts[*]}) over ${transports[*]}: ${pair_modes[*]}"
for transport in "${transports[@]}"; do
  for rm in "${pair_modes[@]}"; do
    read -r rate mode <<< "${rm}"
    for count in "${pair_counts[@]}"; do
      log "  ${transport} ${rate} Hz ${mode} ${count} pairs"
      run_pairs "pairs-${transport}-${rate}-${mode}-${count}" "${transport}" "${rate}" "${mode}" 1 "${count}"
    done
  done
done

# --- 3. the jitter, interleaved -----------------------------------------------------------------------------------
# Each round runs, one right after the other and in alternating order, cyclictest, the loop alone with the processes'
# timer slack (1 ns), the loop alone with the kernel's default slack, and a pair (its master's jitter), all at the
# same settings on the master's CPU.
cyclictest_json() {  # file interval mode > json
  /usr/bin/python3 "${TELEOP_ROOT}/deploy/bench/cyclictest_json.py" "$1" "$2" "$3"
}
jitter_sets=("1000 off")
[[ ${is_root} -eq 1 ]] && jitter_sets=("1000 rt" "8000 rt" "1000 off")
log "interleaved jitter (${rounds} rounds of ${jitter_s} s): ${jitter_sets[*]}"
for js in "${jitter_sets[@]}"; do
  read -r rate mode <<< "${js}"
  interval=$(( 1000000 / rate ))
  for (( r = 0; r < rounds; r++ )); do
    items=(cyclictest loop loop-slack50 pair)
    (( r % 2 == 1 )) && items=(pair loop-slack50 loop cyclictest)
    for item in "${items[@]}"; do
      tag="jitter-${rate}-${mode}-${r}-${item}"
      case "${item}" in
        cyclictest)
          if ! command -v cyclictest > /dev/null; then echo '{"missing": true}' > "${raw}/${tag}.json"; continue; fi
          loops=$(awk "BEGIN {printf \"%d\", ${jitter_s} * 1000000 / ${interval}}")
          if [[ ${mode} == rt ]]; then args=(-p 80 -m -a "${cpu_master}"); else args=(--laptop -p 0); fi
          cyclictest -q -t1 -i "${interval}" -l "${loops}" -h 10000 "${args[@]}" > "${work}/${tag}.txt" 2>&1 || true
          cyclictest_json "${work}/${tag}.txt" "${interval}" "${mode}" > "${raw}/${tag}.json" ;;
        loop|loop-slack50)
          slack=1
          [[ ${item} == loop-slack50 ]] && slack=0
          if [[ ${mode} == rt ]]; then
            "${bin}/teleop-loop-bench" --rate "${rate}" --duration "${jitter_s}" --fifo 80 --cpu "${cpu_master}" --lock \
              --dma-latency-us 0 --timer-slack-ns "${slack}" > "${raw}/${tag}.json" || true
          else
            "${bin}/teleop-loop-bench" --rate "${rate}" --duration "${jitter_s}" --timer-slack-ns "${slack}" \
              > "${raw}/${tag}.json" || true
          fi ;;
        pair)
          # The processes accept 250..8000 Hz; the pair runs free (the master is the clock either way).
          make_config master udp "${rate}" "${mode}" 1 0 | sed 's/^sync: .*/sync: {mode: free}/' > "${work}/m-${tag}.yaml"
          make_config slave udp "${rate}" "${mode}" 1 0 | sed 's/^sync: .*/sync: {mode: free}/' > "${work}/s-${tag}.yaml"
          "${bin}/teleop-slave" --config "${work}/s-${tag}.yaml" --duration "$(awk "BEGIN {print ${jitter_s} + 1.5}")" \
            --summary-json "${raw}/${tag}-slave.json" > "${work}/s-${tag}.log" 2>&1 &
          sp=$!; pids+=("${sp}")
          sleep 0.5
          "${bin}/teleop-master" --config "${work}/m-${tag}.yaml" --duration "${jitter_s}" \
            --summary-json "${raw}/${tag}.json" > "${work}/m-${tag}.log" 2>&1 || log "master ${tag} failed"
          wait "${sp}" || true ;;
      esac
    done
  done
done

# --- 4. compute versus DOF, and the CAN budget -----------------------------------------------------------------------
log "compute per cycle versus DOF (Google Benchmark) and the CAN budget (can_link_benchmark)"
"${bin}/control_benchmark" --benchmark_format=json --benchmark_min_time="${bench_time}" \
  --benchmark_filter='BM_CycleCompute|BM_LawStep' > "${raw}/control_benchmark.json" 2>/dev/null || true
"${bin}/proto_codec_benchmark" --benchmark_format=json --benchmark_min_time="${bench_time}" \
  --benchmark_filter='BM_Encode|BM_Decode' > "${raw}/proto_codec_benchmark.json" 2>/dev/null || true
if [[ -x "${bin}/can_link_benchmark" ]]; then
  "${bin}/can_link_benchmark" --benchmark_filter='^$' > "${work}/can_budget.out" 2>/dev/null || true
  awk '/^\{/ {exit} {print}' "${work}/can_budget.out" > "${raw}/can_budget.txt"
fi

echo "{\"loadavg_end\": \"$(cut -d' ' -f1-3 /proc/loadavg)\", \"idle_states_end\": \"$(idle_states)\", \"elapsed_s\": $(( $(date +%s) - started ))}" \
  > "${raw}/machine_end.json"
mkdir -p "${out_dir}"
/usr/bin/python3 "${TELEOP_ROOT}/deploy/bench/scale_report.py" "${raw}" "${out_dir}"
log "done in $(( $(date +%s) - started )) s: ${out_dir}/performance.md (scale region), ${out_dir}/performance-scale.json, ${out_dir}/performance/*.png"
