#!/usr/bin/env bash
# ctest qemu_socketcan_unit: runs the SocketCAN unit tests (build/tests/can_link_test --gtest_filter=SocketCan.*)
# inside the qemu guest, where AF_CAN and vcan0 exist, and checks that the real-kernel ones ran and passed there
# instead of skipping.
#   tests/qemu/socketcan_unit_test.sh CAN_LINK_TEST_BINARY OUT_DIR
# Exit status: 0 pass, 1 fail, 77 skip (qemu cannot run here).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
binary="${1:?usage: socketcan_unit_test.sh CAN_LINK_TEST_BINARY OUT_DIR}"
out="${2:?usage: socketcan_unit_test.sh CAN_LINK_TEST_BINARY OUT_DIR}"

status=0
"${here}/run_in_guest.sh" --out "${out}" --timeout 90 --bin "${binary}:/usr/local/bin/can_link_test" \
  -- "${here}/socketcan_unit_guest.sh" || status=$?
[[ ${status} -eq 77 ]] && exit 77
log="${out}/gtest.log"
[[ -f "${log}" ]] && cat "${log}"
if [[ ${status} -ne 0 ]]; then
  echo "FAIL: the SocketCAN tests failed in the guest (status ${status}); see ${out}/console.log" >&2
  exit 1
fi
# On a kernel with AF_CAN: the missing-interface and exchange tests must run (not skip); the no-AF_CAN test skips.
for name in SocketCan.MissingInterfaceIsNamed SocketCan.ExchangesSamplesOnARealInterface \
  SocketCan.ReceiveFiltersOnARealInterface; do
  if ! grep -q "^\[       OK \] ${name} " "${log}"; then
    echo "FAIL: ${name} did not run and pass in the guest" >&2
    exit 1
  fi
done
if grep -q "^\[  SKIPPED \] SocketCan.ExchangesSamplesOnARealInterface" "${log}"; then
  echo "FAIL: the exchange test skipped in the guest" >&2
  exit 1
fi
# vcan0 is CAN FD in the guest: the FD half must have run (its summary line), never been skipped.
if grep -q "^FD skipped" "${log}" || ! grep -q "^fd: CAN frames sent" "${log}"; then
  echo "FAIL: the CAN FD exchange did not run in the guest" >&2
  exit 1
fi
cat "${out}/timing.env"
echo "PASS"
