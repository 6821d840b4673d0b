#!/usr/bin/env bash
# The demo on one machine, no hardware: teleop-slave and teleop-master on 127.0.0.1 over UDP at 1 kHz, each with
# its half of the loopback plant. The scripted operator pushes the master so that the slave meets its forbidden-region
# virtual fixture, holds, and pulls back (about 5 s). Prints both summaries; writes telemetry CSVs, JSON summaries
# and the PNGs of deploy/teleop-plot to build/demo/.
#   ./deploy/demo.sh            UDP link
#   ./deploy/demo.sh --can      the same over the emulated CAN bus (for hosts without SocketCAN)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

variant=udp
[[ "${1:-}" == "--can" ]] && variant=can
teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build --target teleop-master teleop-slave

out="${TELEOP_BUILD}/demo"
mkdir -p "${out}"
cfg="${TELEOP_ROOT}/deploy/configs"
master_cfg="${cfg}/master.yaml"
slave_cfg="${cfg}/slave.yaml"
pids=()
cleanup() { for p in "${pids[@]:-}"; do [[ -n "$p" ]] && kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

if [[ "${variant}" == "can" ]]; then
  master_cfg="${cfg}/master-can.yaml"
  slave_cfg="${cfg}/slave-can.yaml"
  teleop::build --target teleop-canbus
  "${TELEOP_BUILD}/bin/teleop-canbus" --port 47300 --bitrate 1000000 --duration-s 12 > "${out}/canbus.log" 2>&1 &
  pids+=($!)
  sleep 0.3
fi

echo "[demo] starting teleop-slave and teleop-master (${variant}, 1 kHz, loopback plant, ~5 s)"
"${TELEOP_BUILD}/bin/teleop-slave" --config "${slave_cfg}" --duration 8 \
  --summary-json "${out}/slave-summary.json" --telemetry-csv "${out}/slave.csv" > "${out}/slave.log" 2>&1 &
slave_pid=$!
pids+=("${slave_pid}")
sleep 0.3
master_rc=0
"${TELEOP_BUILD}/bin/teleop-master" --config "${master_cfg}" --duration 5 \
  --summary-json "${out}/master-summary.json" --telemetry-csv "${out}/master.csv" > "${out}/master.log" 2>&1 ||
  master_rc=$?
slave_rc=0
wait "${slave_pid}" || slave_rc=$?
cleanup  # the emulated bus daemon, if any
pids=()

echo
echo "==== master ===="; cat "${out}/master.log"
echo "==== slave ====";  cat "${out}/slave.log"

echo
"${TELEOP_ROOT}/deploy/teleop-plot" --title "demo (${variant}, 1 kHz)" --out "${out}" "${out}/master.csv" "${out}/slave.csv"
echo
echo "[demo] telemetry: ${out}/master.csv ${out}/slave.csv"
echo "[demo] summaries: ${out}/master-summary.json ${out}/slave-summary.json"
echo "[demo] plots:     ${out}/{master,slave}-{positions,forces,fixture,period,rtt,loss,engagement}.png (deploy/teleop-plot)"
exit $(( master_rc != 0 || slave_rc != 0 ))
