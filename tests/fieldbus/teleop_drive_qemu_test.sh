#!/usr/bin/env bash
# ctest qemu_teleop_drive: teleop-drive and a simulated drive over a real Linux SocketCAN bus (vcan0 in a qemu guest,
# tests/qemu/run_in_guest.sh): scan, info, a segmented SDO read (0x1008), enable and jog in modes 8, 9 and 10, the
# sample EDS accepted and a broken one refused, a segmented SDO write, the hard limit, the deadman (SIGINT), a killed
# tool faulted by the drive's heartbeat consumer, record, fault-reset (teleop_drive_qemu_guest.sh). Each check looks
# in its own subcommand's section of drive.log.
#   tests/fieldbus/teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
binary="${1:?usage: teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR}"
out="${2:?usage: teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR}"
status=0
"${here}/../qemu/run_in_guest.sh" --out "${out}" --timeout 200 --bin "${binary}:/usr/local/bin/teleop-drive" \
  --file "${here}/../../deploy/configs/admittance/simulated-cia402-drive.eds:/guest/drive.eds" \
  -- "${here}/teleop_drive_qemu_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
log="${out}/drive.log"
[[ -f "${log}" ]] && cat "${log}"
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: teleop-drive failed in the guest (status ${status}); see ${out}/console.log" >&2
  exit 1
fi
# section NAME: the output of one subcommand (between its "== NAME" line and the next "== ").
section() { awk -v n="== $1" '$0 == n {on = 1; next} /^== / {on = 0} on' "${log}"; }
expect() {
  section "$1" | grep -qE -- "$2" || { echo "FAIL: no '$2' in section '$1' of ${log}" >&2; exit 1; }
}
expect scan '^3 +pre-operational +0x00020192 0x00000A5A'
expect info 'device name +teleop simulated CiA 402 drive'
expect info 'supported modes +0x00000380: 8 \(cyclic synchronous position\), 9 .*, 10'
expect sdo '^teleop simulated CiA 402 drive$'
for mode in position velocity torque; do
  expect "enable-${mode}" "Operation Enabled, cyclic synchronous ${mode}"
  expect "enable-${mode}" 'stopped after [0-9]+ cycles \(time\).*disabled'
done
expect jog 'stopped after [0-9]+ cycles \(time\).*velocity (1\.9|2\.0)[0-9]* rad/s.*disabled'
expect jog-position 'stopped after [0-9]+ cycles.*velocity -?0\.0[0-9]* rad/s.*disabled'
expect jog-torque 'stopped after .*torque 0\.0500 N·m; disabled'
expect eds 'stopped after [0-9]+ cycles \(time\).*velocity (0\.9|1\.0)[0-9]* rad/s.*disabled'
expect eds-bad 'bad\.eds: \[6060\] DataType is 0x0005 \(UNSIGNED8\), the client uses INTEGER8'
# Nothing was written: the drive is still disabled, in the velocity mode of the last jog (not torque, 10).
expect info-after-bad-eds 'state +(Switch On Disabled|Ready To Switch On)'
expect info-after-bad-eds 'mode display +9$'
expect sdo-write '0x2000:00 written'
expect sdo-read-back '^left arm joint 3 label$'
expect jog-limit '--velocity 5 exceeds --limit 3 \(the hard limit\); nothing was sent'
expect deadman 'stopped after [0-9]+ cycles \(interrupted \(deadman\)\).*disabled'
expect info-after-deadman 'state +Ready To Switch On'
expect killed 'Operation Enabled, cyclic synchronous velocity'
expect info-after-kill 'state +Fault \(statusword 0x0208\)'
expect info-after-kill 'error +0x8130 heartbeat'
expect fault-reset 'node 3: Fault \(statusword 0x0208\), error 0x8130'
expect fault-reset 'after fault reset: Switch On Disabled'
if grep -q '^FAIL' "${log}"; then
  echo "FAIL: $(grep '^FAIL' "${log}" | tr '\n' ' ')" >&2
  exit 1
fi
rows=$(($(wc -l <"${out}/record.csv") - 1))
[[ ${rows} -ge 10 ]] || { echo "FAIL: record.csv has ${rows} rows" >&2; exit 1; }
echo "record: ${rows} rows"
echo "PASS"
