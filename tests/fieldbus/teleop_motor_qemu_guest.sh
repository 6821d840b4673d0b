#!/bin/sh
# Guest half of qemu_teleop_motor: teleop-motor against simulated MIT-mode motors (`teleop-motor simulate`, motors 1
# and 2 in one process, motor 3 with an injected fault in another) over the guest's real-kernel vcan0 switched to CAN
# FD (MTU 72, every frame sent with --fd): scan, info (and a wrong model refused), enable, disable, zero (refused
# without --confirm), jog by position, the hard limit, param write/read, record, a motor that does not exist, a fault
# that stops a jog, and a killed jog (SIGKILL: the motor's own CAN timeout disables it). candump -L captures the bus.
# The emulated guest (TCG) is slow: the cycle runs at 20 ms, answers get 500 ms. Outputs in /out: motor.log,
# simulate.log, record.csv, candump.log.
# shellcheck disable=SC2086  # ${opts} is split into the tool's options on purpose
set -u
iface="${CAN_IFACE:-vcan0}"
ip link set "${iface}" down && ip link set "${iface}" mtu 72 && ip link set "${iface}" up || exit 1
candump -L "${iface}" >/tmp/candump.log &
dump=$!
tool="/usr/local/bin/teleop-motor --models /guest/mit-models.yaml"
${tool} --can "${iface}" --fd simulate --id 1 --id 2 >/out/simulate.log 2>&1 &
sim=$!
usleep 500000
status=0
opts="--can ${iface} --fd --answer-timeout-ms 500 --period-ms 20 --missing-limit 50 --motor-timeout-ms 1500"
# run NAME WANT_RC ARGS...: one subcommand, its output in its own section of motor.log.
run() {
  name="$1"
  want="$2"
  shift 2
  echo "== ${name}" >>/out/motor.log
  ${tool} ${opts} "$@" >>/out/motor.log 2>&1
  rc=$?
  if [ "${rc}" -ne "${want}" ]; then
    echo "FAIL ${name}: exit status ${rc}, expected ${want}" >>/out/motor.log
    status=1
  fi
}
run scan 0 scan --to 4
run info 0 info 1
run info-wrong-model 1 --model DM-J4340 info 1
run enable 0 enable 1
run disable 0 disable 1
run zero-refused 1 zero 1
run zero 0 zero 1 --confirm
run jog-position 0 jog 1 --position 1 --limit 2 --for 2
run jog-limit 1 jog 1 --torque 2 --limit 1 --for 0.3
run param-write 0 param write 1 timeout 200
run param-read 0 param read 1 timeout
run record 0 record 2 --csv /out/record.csv --for 1
run absent 1 enable 5
# Motor 3, its own process, faults 2 s after its start: the jog stops on the motor's code, named.
${tool} --can "${iface}" --fd simulate --id 3 --fault-at-s 2 --fault coil-over-temperature >/out/simulate3.log 2>&1 &
sim3=$!
usleep 300000
run fault 1 jog 3 --velocity 1 --limit 2 --for 20
# A tool that dies (SIGKILL: no deadman) mid-jog: the motor's own CAN timeout (1.5 s) disables it.
echo "== killed" >>/out/motor.log
${tool} ${opts} jog 2 --velocity 1 --limit 2 --for 60 >>/out/motor.log 2>&1 &
jog=$!
sleep 2
kill -KILL "${jog}"
wait "${jog}" 2>/dev/null
sleep 2
run killed-disable 1 disable 2
kill "${sim}" "${sim3}"
wait "${sim}" "${sim3}" 2>/dev/null
usleep 200000
kill "${dump}"
wait "${dump}" 2>/dev/null
cp /tmp/candump.log /out/candump.log
echo "teleop-motor in the guest: status ${status}, candump captured $(wc -l </out/candump.log) frames"
exit "${status}"
