#!/bin/sh
# Guest half of qemu_vcan_smoke: a frame sent with cansend on the real-kernel vcan0 is seen by candump.
# candump -L writes /out/candump.log; the host (vcan_smoke_test.sh) checks it. No sleeps to "let candump start":
# sync frames are sent until candump has logged one, and an end frame marks that everything before it was captured.
set -u
iface="${CAN_IFACE:-vcan0}"

# Sends FRAME every 50 ms until candump's log shows LINE_PATTERN, at most ~10 s. Fails otherwise.
send_until_logged() {
  frame="$1"
  pattern="$2"
  tries=0
  while ! grep -q "${pattern}" /out/candump.log; do
    tries=$((tries + 1))
    if [ "${tries}" -gt 200 ]; then
      echo "candump never logged ${frame}"
      return 1
    fi
    cansend "${iface}" "${frame}" || return 1
    usleep 50000
  done
}

candump -L "${iface}" >/out/candump.log &
candump_pid=$!
send_until_logged "7FF#" " ${iface} 7FF#" || exit 1
cansend "${iface}" 123#DEADBEEF || exit 1
send_until_logged "7FE#" " ${iface} 7FE#" || exit 1
kill "${candump_pid}"
wait "${candump_pid}" 2>/dev/null
for counter in tx_packets rx_packets rx_dropped; do
  echo "${counter}=$(cat "/sys/class/net/${iface}/statistics/${counter}")"
done >/out/link_stats.txt
echo "candump captured $(wc -l </out/candump.log) frames"
