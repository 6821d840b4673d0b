#!/bin/sh
# Guest half of qemu_teleop_can: teleop-slave and teleop-master close the loop over the real-kernel vcan0, candump -L
# captures every frame, and the frames listed in /guest/inject.txt are put on the bus with cansend mid-run.
#   args: FD (0|1) SLAVE_MAX_S
# Inputs: /guest/master.yaml, /guest/slave.yaml, /guest/inject.txt ("<process> <reason> <frame>" per line).
# Outputs in /out: candump.log, master.json, slave.json, master.log, slave.log, injected.txt.
set -u
fd="${1:-0}"
slave_max_s="${2:-30}"
iface="${CAN_IFACE:-vcan0}"

if [ "${fd}" = 1 ]; then
  ip link set "${iface}" down && ip link set "${iface}" mtu 72 && ip link set "${iface}" up || exit 1
fi

# Waits until candump's log has a frame matching PATTERN sent by process PID (at most ~20 s; fails at once when the
# process has exited).
wait_for_frame() {
  deadline=$(($(date +%s) + 20))
  until grep -Eq " ${iface} $1" /tmp/candump.log; do
    if ! kill -0 "$2" 2>/dev/null; then
      echo "the process that should send '$1' exited before it did"
      return 1
    fi
    if [ "$(date +%s)" -gt "${deadline}" ]; then
      echo "no frame matching '$1' on ${iface} after 20 s"
      return 1
    fi
    usleep 50000
  done
}

# The capture goes to tmpfs (no 9p traffic during the run) and is copied to /out at the end.
candump -L "${iface}" >/tmp/candump.log &
candump_pid=$!
usleep 200000

teleop-slave --config /guest/slave.yaml --duration "${slave_max_s}" --summary-json /out/slave.json \
  >/out/slave.log 2>&1 &
slave_pid=$!
wait_for_frame '18[0-4]#' "${slave_pid}" || { cat /out/slave.log; exit 1; }
teleop-master --config /guest/master.yaml --summary-json /out/master.json >/out/master.log 2>&1 &
master_pid=$!
wait_for_frame '10[0-4]#' "${master_pid}" || { cat /out/master.log; exit 1; }

# Mid-run, spaced out so that the loop has time to show any disturbance between them.
usleep 500000
: >/out/injected.txt
while read -r process reason frame; do
  case "${process}" in '' | '#'*) continue ;; esac
  cansend "${iface}" "${frame}" || { echo "cansend ${frame} failed"; exit 1; }
  echo "${process} ${reason} ${frame}" >>/out/injected.txt
  usleep 200000
done </guest/inject.txt

wait "${master_pid}"
master_status=$?
wait "${slave_pid}"
slave_status=$?
usleep 200000
kill "${candump_pid}"
wait "${candump_pid}" 2>/dev/null
cp /tmp/candump.log /out/candump.log
echo "teleop-master exited ${master_status}, teleop-slave exited ${slave_status}," \
  "candump captured $(wc -l </out/candump.log) frames"
[ "${master_status}" = 0 ] && [ "${slave_status}" = 0 ]
