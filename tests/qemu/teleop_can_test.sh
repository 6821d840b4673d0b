#!/usr/bin/env bash
# ctest qemu_teleop_can (GitHub issue 4): teleop-slave and teleop-master close the loop over a real Linux SocketCAN
# bus (vcan0 in a qemu guest, CAN FD, 3 DOF, 500 Hz, loopback plants, 3 s). candump -L captures every frame; mid-run
# cansend injects a frame of wrong length, one with a bad counter, one from a foreign identifier inside the peer's
# filter and one outside it (inject_fd_dof3.txt). On the host, can_capture_check.py checks every captured frame
# against proto/teleop.dbc, that no cycle was lost and the rate was held, and that the processes' JSON summaries
# count exactly the injected frames as rejected, with no loss and no watchdog trip, and that the motion the frames
# carry ends where the static balance puts it (axis 0 held in the slave's fixture, axis 2 in free space). The guest CPU is emulated (TCG)
# on a shared machine, so the rate floor is loose (half the configured rate, TELEOP_QEMU_MIN_RATE_FRACTION); the
# checker also demands that the rate each process reports matches the rate its frames came at on the bus.
#   tests/qemu/teleop_can_test.sh BIN_DIR OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "${here}/../.." && pwd)"
bin_dir="${1:?usage: teleop_can_test.sh BIN_DIR OUT_DIR}"
out="${2:?usage: teleop_can_test.sh BIN_DIR OUT_DIR}"
rate_hz=500
dof=3

for program in teleop-master teleop-slave; do
  [[ -x "${bin_dir}/${program}" ]] || { echo "FAIL: ${bin_dir}/${program} is not built" >&2; exit 1; }
done
python="$( [[ -x /usr/bin/python3 ]] && echo /usr/bin/python3 || command -v python3 || true)"
[[ -n "${python}" ]] || { echo "FAIL: python3 not found (sudo apt-get install python3)" >&2; exit 1; }

status=0
"${here}/run_in_guest.sh" --out "${out}" --timeout 120 \
  --bin "${bin_dir}/teleop-master" --bin "${bin_dir}/teleop-slave" \
  --file "${here}/configs/master_can.yaml:/guest/master.yaml" \
  --file "${here}/configs/slave_can.yaml:/guest/slave.yaml" \
  --file "${here}/inject_fd_dof3.txt:/guest/inject.txt" \
  -- "${here}/teleop_can_guest.sh" 1 20 || status=$?
[[ ${status} -eq 77 ]] && exit 77
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: the guest run failed with status ${status}; see ${out}/guest.log, master.log, slave.log" >&2
  for f in guest.log master.log slave.log; do
    [[ -f "${out}/${f}" ]] && { echo "--- ${f} (last lines)" >&2; tail -n 15 "${out}/${f}" >&2; }
  done
  exit 1
fi

planned="$(grep -Evc '^[[:space:]]*(#|$)' "${here}/inject_fd_dof3.txt")"
done_count="$(wc -l <"${out}/injected.txt")"
if [[ "${planned}" -ne "${done_count}" ]]; then
  echo "FAIL: ${done_count} of ${planned} planned frames were injected" >&2
  exit 1
fi

"${python}" "${here}/can_capture_check.py" --dbc "${root}/proto/teleop.dbc" --log "${out}/candump.log" \
  --dof "${dof}" --fd --rate-hz "${rate_hz}" --min-rate-fraction "${TELEOP_QEMU_MIN_RATE_FRACTION:-0.5}" \
  --master-summary "${out}/master.json" \
  --slave-summary "${out}/slave.json" --injected "${out}/injected.txt" --report "${out}/check_report.json" \
  --master-config "${here}/configs/master_can.yaml" --slave-config "${here}/configs/slave_can.yaml" ||
  { echo "FAIL: see the violations above and ${out}/check_report.json" >&2; exit 1; }
cat "${out}/timing.env"
echo "PASS"
