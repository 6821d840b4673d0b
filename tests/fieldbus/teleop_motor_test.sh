#!/usr/bin/env bash
# teleop-motor against simulated MIT-mode motors on the emulated bus, every subcommand as a process (docs/mit-motors.md,
# "Bring-up with teleop-motor"): teleop-canbus, `teleop-motor simulate` with motors 1 and 2 in one process, then scan,
# info (the ranges against the model, and a wrong model refused), enable, disable, zero (refused without --confirm),
# jog (the hard limit refused before anything is sent), param read/write, record, a motor that does not exist, an
# injected fault (motor 3, its own process) stopping a jog, and a SIGKILLed jog: the motor's own CAN timeout disables it.
# bus-load's budget of a 7-motor rig comes first (no bus).
# Usage: teleop_motor_test.sh BIN_DIR WORK_DIR
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
sim3=""
"${bin}/teleop-canbus" --port "${port}" --stats-every-s 0 >"${work}/canbus.log" 2>&1 &
bus=$!
trap 'kill ${sim3} ${sim} ${bus} 2>/dev/null; wait 2>/dev/null' EXIT
sleep 0.3
"${bin}/teleop-motor" --bus-port "${port}" simulate --id 1 --id 2 >"${work}/simulate.log" 2>&1 &
sim=$!
sleep 0.4
# A generous answer timeout and a tolerance of missing replies: this runs beside the rest of the suite on two cores.
m=("${bin}/teleop-motor" --bus-port "${port}" --answer-timeout-ms 100)
mj=("${m[@]}" --missing-limit 50)
check "bus-load: 7 motors at 1 kHz on classic CAN" 1 "7 motors at 1000 Hz: load 1\.89 of the bus \(does not fit\); within 80 %: 2 motors per bus" -- "${bin}/teleop-motor" bus-load --motors 7 --rate-hz 1000
check "bus-load: on CAN FD 1/5 Mbit/s" 0 "7 motors at 1000 Hz: load 0\.79 of the bus \(fits\)" -- "${bin}/teleop-motor" --fd bus-load --motors 7 --rate-hz 1000
check "scan finds motor 1" 0 "^motor 0x01: answers on master id 0x11$" -- "${m[@]}" scan --to 3
out=$("${m[@]}" scan --to 3 2>&1)
if grep -q "^motor 0x02: answers on master id 0x12$" <<<"${out}" && ! grep -q "motor 0x03" <<<"${out}" &&
  grep -q "^2 motors answered (ids 1..3)$" <<<"${out}"; then
  echo "ok   scan finds motor 2, not 3"
else
  echo "FAIL scan finds motor 2, not 3:"
  echo "${out}" | sed 's/^/    /'
  fail=1
fi
check "info: the ranges" 0 "P_MAX 12.5 rad, V_MAX 30 rad/s, T_MAX 10 N·m on the motor; model DM-J4310: 12.5, 30, 10" -- "${m[@]}" info 1
check "info: ranges match the model" 0 "^  ranges match the model$" -- "${m[@]}" info 2
check "info: a wrong model names T_MAX" 1 "T_MAX \(register 23\) is 10 on the motor but 28 in the config" -- "${m[@]}" --model DM-J4340 info 1
check "enable" 0 "^motor 0x01: enabled \(code 0x1\)" -- "${m[@]}" enable 1
check "disable" 0 "^motor 0x01: disabled \(code 0x0\)" -- "${m[@]}" disable 1
check "zero without --confirm is refused" 1 "zero: the joint's zero moves, and every calibration with it: add --confirm" -- "${m[@]}" zero 1
check "zero --confirm" 0 "^motor 0x01: disabled \(code 0x0\), position -?0\.000[0-9] rad" -- "${m[@]}" zero 1 --confirm
# Exit 0 is a stop by --for; the state line is the motor's answer to the final disable.
check "jog torque, disabled at the end" 0 "^motor 0x01: disabled \(code 0x0\)" -- "${mj[@]}" jog 1 --torque 0.5 --limit 1 --for 0.3
check "jog beyond the hard limit is refused" 1 "--torque 2 exceeds --limit 1 \(the hard limit\); nothing was sent" -- "${m[@]}" jog 1 --torque 2 --limit 1 --for 0.3
check "param read" 0 "^register 9 = [0-9]+ " -- "${m[@]}" param read 1 timeout
check "param write" 0 "^register 9 written" -- "${m[@]}" param write 1 timeout 200
check "param read back" 0 "^register 9 = 200 \(0xC8\)$" -- "${m[@]}" param read 1 timeout
check "record" 0 "stopped: --for 0\.3 s done" -- "${mj[@]}" record 2 --csv "${work}/record.csv" --for 0.3
rows=$(($(wc -l <"${work}/record.csv") - 1))
if [[ ${rows} -lt 50 ]] || ! head -1 "${work}/record.csv" | grep -q "^t_s,position_rad,velocity_rad_per_s,torque_Nm,status"; then
  echo "FAIL record: ${rows} rows"
  fail=1
else
  echo "ok   record: ${rows} rows"
fi
check "a motor that does not exist" 1 "motor 0x05: no answer to enable within 20 ms .*master id 0x15" -- "${bin}/teleop-motor" --bus-port "${port}" enable 5
check "a motor that does not exist: info" 1 "motor 0x05: no answer to the read of TIMEOUT" -- "${bin}/teleop-motor" --bus-port "${port}" info 5
# An injected fault (motor 3 in its own process, 0.5 s after its start) stops a jog, naming the fault.
"${bin}/teleop-motor" --bus-port "${port}" simulate --id 3 --fault-at-s 0.5 --fault coil-over-temperature \
  >"${work}/simulate3.log" 2>&1 &
sim3=$!
sleep 0.2
check "a fault stops the jog" 1 "stopped: the motor reports coil over-temperature \(code 0xC\)" -- "${mj[@]}" jog 3 --velocity 1 --limit 2 --for 5
# A tool that dies (SIGKILL: no deadman runs) mid-jog: the motor's own CAN timeout (--motor-timeout-ms, set before
# the jog) disables it and it reports "communication lost".
"${mj[@]}" jog 2 --velocity 1 --limit 2 --for 30 >"${work}/killed.log" 2>&1 &
jog=$!
sleep 0.5
{
  kill -KILL ${jog}
  wait ${jog}
} 2>/dev/null
sleep 0.3
check "killed jog: the motor disabled itself" 1 "^motor 0x02: communication lost \(code 0xD\)" -- "${m[@]}" disable 2
check "killed jog: clear" 0 "^motor 0x02: disabled \(code 0x0\)" -- "${m[@]}" clear 2
exit ${fail}
