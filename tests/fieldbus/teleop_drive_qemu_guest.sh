#!/bin/sh
# Guest half of qemu_teleop_drive: teleop-drive against a simulated drive (`teleop-drive simulate`, node 3) over the
# guest's real-kernel vcan0 — scan, info, sdo read (0x1008, a segmented string), enable and jog in each mode (8
# position, 9 velocity, 10 torque), the sample EDS checked (accepted) and a broken copy of it (refused, nothing
# enabled), record, fault-reset.
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
run enable-position enable 3 --mode position --limit 1 --for 0.5
run enable-velocity enable 3 --mode velocity --limit 1 --for 0.5
run enable-torque enable 3 --mode torque --limit 0.1 --for 0.5
run jog jog 3 --velocity 2 --limit 3 --for 2
run jog-position jog 3 --position 0.5 --limit 2 --for 2
run jog-torque jog 3 --torque 0.05 --limit 0.1 --for 1
# The shipped EDS (CiA 306) of the simulated drive: checked before the drive is touched, then a jog.
run eds --eds /guest/drive.eds jog 3 --velocity 1 --limit 2 --for 1
# A copy with 0x6060 typed UNSIGNED8: refused, naming file, section and key; the drive left disabled.
sed '/^\[6060\]/,/^$/s/^DataType=0x0002/DataType=0x0005/' /guest/drive.eds >/tmp/bad.eds
echo "== eds-bad" >>/out/drive.log
if "${drive}" --can "${iface}" --sdo-timeout-ms 200 --period-ms 20 --eds /tmp/bad.eds enable 3 --mode torque \
  --limit 0.1 --for 0.5 >>/out/drive.log 2>&1; then
  echo "FAIL eds-bad: accepted" >>/out/drive.log
  status=1
fi
run info-after-bad-eds info 3
run record record 3 --csv /out/record.csv --for 1
run fault-reset fault-reset 3
kill "${sim}"
wait "${sim}" 2>/dev/null
echo "teleop-drive in the guest: status ${status}"
exit "${status}"
