#!/usr/bin/env bash
# teleop-drive against simulated drives on the emulated bus, every subcommand as a process (docs/cia402.md,
# "Bring-up with teleop-drive"): teleop-canbus, `teleop-drive simulate` with nodes 3 (faults at 6 s), 5 and 7 (torque
# mode only), each in its own process,
# then scan, info, sdo read/write (a segmented string too), enable, jog in each mode with the hard limit, record,
# the deadman (SIGINT mid-jog), fault-reset, and the clear errors: a silent node, an abort with its text, a limit.
# Usage: teleop_drive_test.sh BIN_DIR WORK_DIR
set -u
bin="$1"
work="$2"
mkdir -p "${work}"
port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
fail=0
check() {  # check NAME EXPECTED_RC PATTERN -- command...
  local name="$1" want_rc="$2" pattern="$3"
  shift 4
  local out rc
  out=$("$@" 2>&1)
  rc=$?
  if [[ ${rc} -ne ${want_rc} ]] || ! grep -qE -- "${pattern}" <<<"${out}"; then
    echo "FAIL ${name}: exit ${rc} (want ${want_rc}), output:"
    echo "${out}" | sed 's/^/    /'
    fail=1
  else
    echo "ok   ${name}"
  fi
}
"${bin}/teleop-canbus" --port "${port}" --stats-every-s 0 >"${work}/canbus.log" 2>&1 &
bus=$!
sleep 0.3
# Node 3 faults at 6 s; node 5 in its own process, so the injected fault never lands in one of its runs.
"${bin}/teleop-drive" --bus-port "${port}" simulate --node 3 --fault-at-s 6 >"${work}/simulate.log" 2>&1 &
sim=$!
"${bin}/teleop-drive" --bus-port "${port}" simulate --node 5 >"${work}/simulate5.log" 2>&1 &
sim5=$!
"${bin}/teleop-drive" --bus-port "${port}" simulate --node 7 --supported-modes 0x200 >"${work}/simulate7.log" 2>&1 &
sim7=$!
trap 'kill ${sim} ${sim5} ${sim7} ${bus} 2>/dev/null; wait 2>/dev/null' EXIT
sleep 0.5
# Generous staleness and heartbeat timeouts: this runs beside the rest of the suite on two cores, where three
# cycles of a 20 ms gap (the default ten cycles) happen; the stale and heartbeat stops are unit-tested in
# cia402_drive_test.
d=("${bin}/teleop-drive" --bus-port "${port}" --stale-ms 250 --heartbeat-timeout-ms 1000 --drive-consumer-timeout-ms 1500)
# A node that answers is missed when its simulate process is descheduled past the scan timeout: 200 ms per node
# here (the tool's default suits an idle bus).
check "scan finds nodes 3 and 5" 0 "^3 +pre-operational +0x00020192 0x00000A5A.*CiA 402 drive" -- "${d[@]}" scan --to 8 --timeout-ms 200
check "scan reports the count" 0 "3 nodes found in 1..8 \(timeout 200 ms per node\)" -- "${d[@]}" scan --to 8 --timeout-ms 200
check "info: device name (segmented)" 0 "device name +teleop simulated CiA 402 drive" -- "${d[@]}" info 5
check "info: modes" 0 "supported modes +0x00000380: 8 \(cyclic synchronous position\), 9 .*, 10" -- "${d[@]}" info 5
check "sdo read" 0 "0x6502:00 = 0x00000380" -- "${d[@]}" sdo read 5 0x6502 0
check "sdo write string (segmented)" 0 "0x2000:00 written" -- "${d[@]}" sdo write 5 0x2000 0 "left arm joint 3 label" --type string
check "sdo read string back" 0 "^left arm joint 3 label$" -- "${d[@]}" sdo read 5 0x2000 0 --type string
check "sdo abort with its text" 1 "aborted: 0x06020000 Object does not exist in the object dictionary" -- "${d[@]}" sdo read 5 0x6099 0
check "sdo abort on a read-only object" 1 "0x06010002 Attempt to write a read only object" -- "${d[@]}" sdo write 5 0x1000 0 1
check "a node that does not answer" 1 "0x1000:00 on node 9: no response within 20 ms" -- "${d[@]}" --sdo-timeout-ms 20 --sdo-retries 0 info 9
check "enable velocity" 0 "stopped after [0-9]+ cycles \(time\).*disabled" -- "${d[@]}" enable 5 --mode velocity --limit 1 --for 0.2
check "jog velocity follows" 0 "velocity 2\.0[0-9]* rad/s.*disabled" -- "${d[@]}" jog 5 --velocity 2 --limit 3 --for 0.5
check "jog beyond the hard limit is refused" 1 "--velocity 5 exceeds --limit 3 \(the hard limit\); nothing was sent" -- "${d[@]}" jog 5 --velocity 5 --limit 3 --for 0.5
check "jog position, 0.5 rad at <= 2 rad/s" 0 "stopped after [0-9]+ cycles.*velocity -?0\.0[0-9]* rad/s.*disabled" -- "${d[@]}" jog 5 --position 0.5 --limit 2 --for 0.6
check "jog torque" 0 "stopped after .*torque 0\.0500 N·m; disabled" -- "${d[@]}" jog 5 --torque 0.05 --limit 0.1 --for 0.3
check "record" 0 "stopped after" -- "${d[@]}" record 5 --csv "${work}/record.csv" --for 0.3
rows=$(($(wc -l <"${work}/record.csv") - 1))
if [[ ${rows} -lt 50 ]] || ! head -1 "${work}/record.csv" | grep -q "^t_s,status,state,statusword,position_rad"; then
  echo "FAIL record: ${rows} rows"
  fail=1
else
  echo "ok   record: ${rows} rows"
fi
check "a mode the drive lacks" 1 "the drive does not support cyclic synchronous velocity \(0x6502 = 0x00000200, bit 8 clear\)" -- "${d[@]}" enable 7 --mode velocity --limit 1 --for 0.1
check "nothing enabled on it" 0 "state +Switch On Disabled" -- "${d[@]}" info 7
check "a rated torque that differs" 1 "rated torque 0x6076 is 1 N·m, the configuration says 2 N·m" -- "${d[@]}" --rated-torque 2 enable 5 --mode torque --limit 0.1 --for 0.1
# The deadman: SIGINT in the middle of a 30 s jog stops the motor at once.
"${d[@]}" jog 5 --velocity 1 --limit 2 --for 30 >"${work}/deadman.log" 2>&1 &
jog=$!
sleep 1.0
kill -INT ${jog}
start=$(date +%s%N)
wait ${jog}
rc=$?
elapsed_ms=$((($(date +%s%N) - start) / 1000000))
if grep -q "interrupted (deadman).*disabled" "${work}/deadman.log" && [[ ${elapsed_ms} -lt 2000 ]]; then
  echo "ok   deadman: stopped ${elapsed_ms} ms after SIGINT (exit ${rc})"
else
  echo "FAIL deadman: exit ${rc} after ${elapsed_ms} ms"
  sed 's/^/    /' "${work}/deadman.log"
  fail=1
fi
check "disabled after the deadman" 0 "state +Ready To Switch On" -- "${d[@]}" info 5
# Node 3 faults at 6 s (EMCY 0x2310): fault-reset clears it; the history keeps it.
for _ in $(seq 1 100); do
  "${d[@]}" sdo read 3 0x6041 0 --type u16 2>/dev/null | grep -q "0x0208" && break
  sleep 0.1
done
check "info: in Fault" 0 "state +Fault \(statusword 0x0208\)" -- "${d[@]}" info 3
check "fault-reset" 0 "after fault reset: Switch On Disabled \(statusword 0x0240\)" -- "${d[@]}" fault-reset 3
check "info: error history" 0 "1: 0x2310" -- "${d[@]}" info 3
# A tool that dies (SIGKILL: no deadman can run) mid-jog: the drive's consumer of the tool's heartbeat (0x1016,
# --drive-consumer-timeout-ms) faults it (EMCY 0x8130) and the motor stops; fault-reset recovers it.
"${d[@]}" jog 5 --velocity 1 --limit 2 --for 30 >"${work}/killed.log" 2>&1 &
jog=$!
for _ in $(seq 1 50); do
  grep -q "Operation Enabled" "${work}/killed.log" && break
  sleep 0.1
done
sleep 0.3
{
  kill -KILL ${jog}
  wait ${jog}
} 2>/dev/null
check "killed tool: still enabled at first" 0 "0x6041:00 = 0x[0-9A-F]{2}37 " -- "${d[@]}" sdo read 5 0x6041 0 --type u16
for _ in $(seq 1 60); do
  "${d[@]}" sdo read 5 0x6041 0 --type u16 2>/dev/null | grep -q "0x0208" && break
  sleep 0.1
done
check "killed tool: the drive faulted itself (heartbeat)" 0 "error +0x8130 heartbeat" -- "${d[@]}" info 5
check "killed tool: fault-reset" 0 "after fault reset: Switch On Disabled" -- "${d[@]}" fault-reset 5
# A clean stop switches the consumer off again: no fault after the tool has gone.
check "clean stop" 0 "stopped after .*disabled" -- "${d[@]}" jog 5 --velocity 1 --limit 2 --for 0.3
sleep 2.0
check "clean stop: no fault after the tool has gone" 0 "state +Ready To Switch On" -- "${d[@]}" info 5
exit ${fail}
