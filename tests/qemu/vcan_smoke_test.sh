#!/usr/bin/env bash
# ctest qemu_vcan_smoke: boots the qemu guest (real Linux SocketCAN), sends 123#DEADBEEF on vcan0 with cansend and
# checks on the host that candump -L captured exactly that frame, once, in a well-formed log.
#   tests/qemu/vcan_smoke_test.sh OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out="${1:?usage: vcan_smoke_test.sh OUT_DIR}"

status=0
"${here}/run_in_guest.sh" --out "${out}" --timeout 90 -- "${here}/vcan_smoke_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: the guest script failed with status ${status}; see ${out}/console.log" >&2
  exit 1
fi
log="${out}/candump.log"
[[ -s "${log}" ]] || { echo "FAIL: ${log} is missing or empty" >&2; exit 1; }

# candump -L: "(seconds.micro) iface ID#DATA", one frame a line.
malformed="$(grep -Evc '^\([0-9]+\.[0-9]{6}\) vcan0 [0-9A-F]{3}#([0-9A-F]{2}){0,8}$' "${log}" || true)"
hits="$(grep -Ec '^\([0-9]+\.[0-9]{6}\) vcan0 123#DEADBEEF$' "${log}" || true)"
echo "candump.log: $(wc -l <"${log}") frames, ${hits} x 123#DEADBEEF, ${malformed} malformed lines"
if [[ "${malformed}" -ne 0 ]]; then
  echo "FAIL: candump.log has lines that are not candump -L frames:" >&2
  grep -Ev '^\([0-9]+\.[0-9]{6}\) vcan0 [0-9A-F]{3}#([0-9A-F]{2}){0,8}$' "${log}" | head -n 5 >&2
  exit 1
fi
if [[ "${hits}" -ne 1 ]]; then
  echo "FAIL: expected exactly one 123#DEADBEEF on vcan0, found ${hits}" >&2
  exit 1
fi
# The frame was sent after the first 7FF# sync frame and before the first 7FE# end frame: order is preserved.
order="$(grep -Eo '(7FF#|123#DEADBEEF|7FE#)' "${log}" | uniq | tr '\n' ' ')"
if [[ "${order}" != "7FF# 123#DEADBEEF 7FE# " ]]; then
  echo "FAIL: frames out of order on the bus: ${order}" >&2
  exit 1
fi
cat "${out}/timing.env"
echo "PASS"
