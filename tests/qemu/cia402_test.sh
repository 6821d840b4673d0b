#!/usr/bin/env bash
# ctest qemu_cia402: the CiA 402 client and the simulated drive over a real Linux SocketCAN bus (vcan0 in a qemu
# guest): NMT, SDO set-up with the PDO mapping read back, the state machine to Operation Enabled, 2 s of cyclic
# synchronous torque at 50 Hz, a drive fault with EMCY and its fault reset. On the host: the test ran and passed
# (not skipped), the candump -L capture holds the bring-up in order, and can-utils' log2asc reads the capture.
#   tests/qemu/cia402_test.sh FIELDBUS_CAN_TEST_BINARY OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
binary="${1:?usage: cia402_test.sh FIELDBUS_CAN_TEST_BINARY OUT_DIR}"
out="${2:?usage: cia402_test.sh FIELDBUS_CAN_TEST_BINARY OUT_DIR}"

status=0
"${here}/run_in_guest.sh" --out "${out}" --timeout 120 --bin "${binary}:/usr/local/bin/fieldbus_can_test" \
  -- "${here}/cia402_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
log="${out}/gtest.log"
[[ -f "${log}" ]] && cat "${log}"
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: the CiA 402 test failed in the guest (status ${status}); see ${out}/console.log" >&2
  exit 1
fi
name=Cia402OnSocketCan.BringsUpAndRunsTorqueModeOnARealInterface
if ! grep -q "^\[       OK \] ${name} " "${log}"; then
  echo "FAIL: ${name} did not run and pass in the guest" >&2
  exit 1
fi
capture="${out}/candump.log"
# The bring-up in order (node 1): NMT reset, boot-up, the mode write (0x6060 = 10), NMT start, enable operation,
# then RPDO, SYNC, TPDO1, TPDO2, and the EMCY of the injected overcurrent.
at=0
for step in ' 000#8101$' ' 701#00$' ' 601#2F6060000A000000$' ' 000#0101$' ' 601#2B4060000F000000$' ' 201#0F006400$' \
  ' 080#$' ' 181#' ' 281#' ' 081#102303'; do
  line="$(tail -n +"$((at + 1))" "${capture}" | grep -nE -m1 -- "${step}" | cut -d: -f1 || true)"
  if [[ -z "${line}" ]]; then
    echo "FAIL: the capture has no '${step}' after line ${at} (${capture})" >&2
    exit 1
  fi
  at=$((at + line))
done
syncs="$(grep -cE ' 080#$' "${capture}")"
tpdos="$(grep -cE ' 181#' "${capture}")"
echo "capture: $(wc -l <"${capture}") frames, ${syncs} SYNC, ${tpdos} TPDO1"
[[ ${syncs} -ge 100 && ${tpdos} -ge 100 ]] || { echo "FAIL: too few SYNC/TPDO frames on the bus" >&2; exit 1; }
if command -v log2asc >/dev/null; then
  log2asc -I "${capture}" -O "${out}/candump.asc" vcan0
  asc="$(grep -cE '^ *[0-9]+\.[0-9]+ +[0-9]+ +' "${out}/candump.asc" || true)"
  [[ ${asc} -eq $(wc -l <"${capture}") ]] || { echo "FAIL: log2asc converted ${asc} frames" >&2; exit 1; }
  echo "log2asc: ${asc} frames"
fi
cat "${out}/timing.env"
echo "PASS"
