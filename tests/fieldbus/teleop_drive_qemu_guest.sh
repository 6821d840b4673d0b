#!/bin/sh
# Guest half of qemu_teleop_drive: teleop-drive against a simulated drive (`teleop-drive simulate`, node 3) over the
# guest's real-kernel vcan0 — scan, info, sdo read (a segmented string), a velocity jog, record, fault-reset.
# The emulated guest (TCG) is slow: the cycle runs at 20 ms. Outputs in /out: drive.log, simulate.log, record.csv.
set -u
iface="${CAN_IFACE:-vcan0}"
drive="/usr/local/bin/teleop-drive"
"${drive}" --can "${iface}" simulate --node 3 >/out/simulate.log 2>&1 &
sim=$!
usleep 500000
status=0
run() {
  name="$1"
  shift
  echo "== ${name}" >>/out/drive.log
  if ! "${drive}" --can "${iface}" --sdo-timeout-ms 200 --period-ms 20 "$@" >>/out/drive.log 2>&1; then
    echo "FAIL ${name}" >>/out/drive.log
    status=1
  fi
}
run scan scan --to 5 --timeout-ms 100
run info info 3
run sdo sdo read 3 0x1008 0 --type string
run jog jog 3 --velocity 2 --limit 3 --for 2
run record record 3 --csv /out/record.csv --for 1
run fault-reset fault-reset 3
kill "${sim}"
wait "${sim}" 2>/dev/null
echo "teleop-drive in the guest: status ${status}"
exit "${status}"
