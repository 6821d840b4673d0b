#!/usr/bin/env bash
# ctest qemu_teleop_drive: teleop-drive and a simulated drive over a real Linux SocketCAN bus (vcan0 in a qemu guest,
# tests/qemu/run_in_guest.sh): every read-only subcommand, a jog and a record (teleop_drive_qemu_guest.sh).
#   tests/fieldbus/teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
binary="${1:?usage: teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR}"
out="${2:?usage: teleop_drive_qemu_test.sh TELEOP_DRIVE_BINARY OUT_DIR}"
status=0
"${here}/../qemu/run_in_guest.sh" --out "${out}" --timeout 120 --bin "${binary}:/usr/local/bin/teleop-drive" \
  -- "${here}/teleop_drive_qemu_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
log="${out}/drive.log"
[[ -f "${log}" ]] && cat "${log}"
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: teleop-drive failed in the guest (status ${status}); see ${out}/console.log" >&2
  exit 1
fi
for pattern in '^3 +pre-operational +0x00020192 0x00000A5A' 'device name +teleop simulated CiA 402 drive' \
  '^teleop simulated CiA 402 drive$' 'stopped after [0-9]+ cycles \(time\).*velocity (1\.9|2\.0)[0-9]* rad/s.*disabled' \
  'after fault reset: '; do
  grep -qE -- "${pattern}" "${log}" || { echo "FAIL: no '${pattern}' in ${log}" >&2; exit 1; }
done
rows=$(($(wc -l <"${out}/record.csv") - 1))
[[ ${rows} -ge 10 ]] || { echo "FAIL: record.csv has ${rows} rows" >&2; exit 1; }
echo "record: ${rows} rows"
echo "PASS"
