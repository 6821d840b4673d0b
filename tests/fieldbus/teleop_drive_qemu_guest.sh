#!/bin/sh
# Guest half of qemu_teleop_drive: teleop-drive against a simulated drive (`teleop-drive simulate`, node 3) over the
# guest's real-kernel vcan0 — scan, info, sdo read (0x1008, a segmented string), enable and jog in each mode (8
# position, 9 velocity, 10 torque), the sample EDS checked (accepted) and a broken copy of it (refused, nothing
# enabled), a segmented SDO write read back, the hard limit, the deadman (SIGINT mid-jog), a killed tool (SIGKILL: the
# drive's heartbeat consumer faults it), record, fault-reset of that fault.
# The emulated guest (TCG) is slow: the cycle runs at 20 ms. Outputs in /out: drive.log, simulate.log, record.csv.
# shellcheck disable=SC2086  # ${opts} is split into the tool's options on purpose
set -u
iface="${CAN_IFACE:-vcan0}"
drive="/usr/local/bin/teleop-drive"
"${drive}" --can "${iface}" simulate --node 3 >/out/simulate.log 2>&1 &
sim=$!
usleep 500000
status=0
# wait_for FILE TEXT: up to 30 s for TEXT to appear in FILE, then half a second more.
wait_for() {
  n=0
  while [ "${n}" -lt 300 ] && ! grep -q "$2" "$1" 2>/dev/null; do
    usleep 100000
    n=$((n + 1))
  done
  usleep 500000
}
# The drive's consumer of the tool's heartbeat at 2 s: the emulated CPU may hold the tool up for a few hundred ms.
opts="--can ${iface} --sdo-timeout-ms 200 --period-ms 20 --drive-consumer-timeout-ms 2000"
run() {
  name="$1"
  shift
  echo "== ${name}" >>/out/drive.log
  if ! "${drive}" ${opts} "$@" >>/out/drive.log 2>&1; then
    echo "FAIL ${name}" >>/out/drive.log
    status=1
  fi
}
run scan scan --to 5 --timeout-ms 100
run info info 3
run sdo sdo read 3 0x1008 0 --type string
# A segmented download (22 bytes to the label 0x2000), read back segmented.
run sdo-write sdo write 3 0x2000 0 "left arm joint 3 label" --type string
run sdo-read-back sdo read 3 0x2000 0 --type string
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
# The hard limit: refused before anything is sent.
echo "== jog-limit" >>/out/drive.log
if "${drive}" ${opts} jog 3 --velocity 5 --limit 3 --for 1 >>/out/drive.log 2>&1; then
  echo "FAIL jog-limit: accepted" >>/out/drive.log
  status=1
fi
# The deadman: SIGINT in the middle of a 60 s jog stops the motor (target 0, disabled).
echo "== deadman" >>/out/drive.log
"${drive}" ${opts} jog 3 --velocity 1 --limit 2 --for 60 >/tmp/deadman.log 2>&1 &
jog=$!
wait_for /tmp/deadman.log "Operation Enabled"
kill -INT "${jog}"
wait "${jog}" || echo "FAIL deadman: exit status $?" >>/out/drive.log
cat /tmp/deadman.log >>/out/drive.log
run info-after-deadman info 3
# A tool that dies (SIGKILL) mid-jog cannot run its deadman: the drive's heartbeat consumer (0x1016) faults it.
echo "== killed" >>/out/drive.log
"${drive}" ${opts} jog 3 --velocity 1 --limit 2 --for 60 >/tmp/killed.log 2>&1 &
jog=$!
wait_for /tmp/killed.log "Operation Enabled"
kill -KILL "${jog}"
wait "${jog}" 2>/dev/null
cat /tmp/killed.log >>/out/drive.log
i=0
while [ "${i}" -lt 50 ]; do
  "${drive}" ${opts} sdo read 3 0x6041 0 --type u16 2>/dev/null | grep -q "0x0208" && break
  usleep 200000
  i=$((i + 1))
done
run info-after-kill info 3
run fault-reset fault-reset 3
kill "${sim}"
wait "${sim}" 2>/dev/null
echo "teleop-drive in the guest: status ${status}"
exit "${status}"
