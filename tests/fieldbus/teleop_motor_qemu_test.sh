#!/usr/bin/env bash
# ctest qemu_teleop_motor: teleop-motor and simulated MIT-mode motors over a real Linux SocketCAN bus in CAN FD (vcan0
# at MTU 72 in a qemu guest, tests/qemu/run_in_guest.sh): every subcommand of docs/mit-motors.md's walkthrough, the
# refusals, a fault named, a killed jog disabled by the motor's own timeout (teleop_motor_qemu_guest.sh). Each check
# looks in its own subcommand's section of motor.log; the capture must hold the enable and the feedback as CAN FD
# frames, and no classic frame but the parameter protocol's.
#   tests/fieldbus/teleop_motor_qemu_test.sh TELEOP_MOTOR_BINARY OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
binary="${1:?usage: teleop_motor_qemu_test.sh TELEOP_MOTOR_BINARY OUT_DIR}"
out="${2:?usage: teleop_motor_qemu_test.sh TELEOP_MOTOR_BINARY OUT_DIR}"
status=0
"${here}/../qemu/run_in_guest.sh" --out "${out}" --timeout 120 --bin "${binary}:/usr/local/bin/teleop-motor" \
  --file "${here}/../../deploy/motors/mit-models.yaml:/guest/mit-models.yaml" \
  -- "${here}/teleop_motor_qemu_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
log="${out}/motor.log"
[[ -f "${log}" ]] && cat "${log}"
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: teleop-motor failed in the guest (status ${status}); see ${out}/console.log" >&2
  exit 1
fi
# section NAME: the output of one subcommand (between its "== NAME" line and the next "== ").
section() { awk -v n="== $1" '$0 == n {on = 1; next} /^== / {on = 0} on' "${log}"; }
expect() {
  section "$1" | grep -qE -- "$2" || { echo "FAIL: no '$2' in section '$1' of ${log}" >&2; exit 1; }
}
expect scan '^motor 0x01: answers on master id 0x11$'
expect scan '^motor 0x02: answers on master id 0x12$'
expect scan '^2 motors answered \(ids 1\.\.4\)$'
expect info 'P_MAX 12\.5 rad, V_MAX 30 rad/s, T_MAX 10 N·m on the motor; model DM-J4310: 12\.5, 30, 10'
expect info '^  ranges match the model$'
expect info-wrong-model 'T_MAX \(register 23\) is 10 on the motor but 28 in the config'
expect enable '^motor 0x01: enabled \(code 0x1\)'
expect disable '^motor 0x01: disabled \(code 0x0\)'
expect zero-refused 'add --confirm'
expect zero '^motor 0x01: disabled \(code 0x0\), position -?0\.000[0-9] rad'
expect jog-position '^motor 0x01: disabled \(code 0x0\), position 0\.9[0-9]* rad'
expect jog-position 'stopped: --for 2 s done'
expect jog-limit '--torque 2 exceeds --limit 1 \(the hard limit\); nothing was sent'
expect param-write '^register 9 written'
expect param-read '^register 9 = 200 \(0xC8\)$'
expect record 'stopped: --for 1 s done'
expect absent 'motor 0x05: no answer to enable within 500 ms'
expect fault 'stopped: the motor reports coil over-temperature \(code 0xC\)'
expect killed-disable '^motor 0x02: communication lost \(code 0xD\)'
if grep -q '^FAIL' "${log}"; then
  echo "FAIL: $(grep '^FAIL' "${log}" | tr '\n' ' ')" >&2
  exit 1
fi
rows=$(($(wc -l <"${out}/record.csv") - 1))
[[ ${rows} -ge 10 ]] || { echo "FAIL: record.csv has ${rows} rows" >&2; exit 1; }
# CAN FD on the wire (candump -L: ID##<flags><data>): motor 1's enable (seven FF, then FC) and its feedback on master
# id 0x11 saying enabled (D0 = 0x11: motor 1, code 1).
capture="${out}/candump.log"
grep -qE ' 001##[0-9A-F]FFFFFFFFFFFFFFFC$' "${capture}" || { echo "FAIL: no CAN FD enable of motor 1 in ${capture}" >&2; exit 1; }
grep -qE ' 011##[0-9A-F]11' "${capture}" || { echo "FAIL: no CAN FD feedback 'motor 1 enabled' in ${capture}" >&2; exit 1; }
# Classic frames only for the parameter protocol (requests on 0x7FF, answers with op 0x33/0x55 in D2): the codec
# sends those classic, which an FD controller takes; every command, special frame and feedback is CAN FD.
other="$(grep -E ' [0-9A-F]{3}#[0-9A-F]' "${capture}" | grep -cvE ' [0-9A-F]{3}#[0-9A-F]{4}(33|55)' || true)"
[[ ${other} -eq 0 ]] || { echo "FAIL: ${other} classic frames besides parameter frames in ${capture}" >&2; exit 1; }
fd="$(grep -c '##' "${capture}" || true)"
echo "record: ${rows} rows; capture: ${fd} CAN FD frames, $(grep -cE ' [0-9A-F]{3}#[0-9A-F]' "${capture}") classic parameter frames"
cat "${out}/timing.env"
echo "PASS"
