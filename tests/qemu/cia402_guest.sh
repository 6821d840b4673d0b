#!/bin/sh
# Guest half of qemu_cia402: the CiA 402 client brings the simulated drive up over the real-kernel vcan0 and runs
# it in cyclic synchronous torque mode (tests/fieldbus/cia402_socketcan_test.cpp), while candump -L captures every
# frame. Outputs in /out: gtest.log, candump.log.
set -u
iface="${CAN_IFACE:-vcan0}"
candump -L "${iface}" >/tmp/candump.log &
candump_pid=$!
usleep 200000
CAN_IFACE="${iface}" /usr/local/bin/fieldbus_can_test --gtest_filter='Cia402OnSocketCan.*' >/out/gtest.log 2>&1
status=$?
usleep 200000
kill "${candump_pid}"
wait "${candump_pid}" 2>/dev/null
cp /tmp/candump.log /out/candump.log
echo "fieldbus_can_test exit status ${status}, candump captured $(wc -l </out/candump.log) frames"
exit "${status}"
