#!/bin/sh
# Guest half of qemu_socketcan_unit: the SocketCAN gtests of tests/can/can_socket_test.cpp, which skip on a host
# without AF_CAN, run here against the real kernel stack on vcan0.
set -u
CAN_IFACE="${CAN_IFACE:-vcan0}" /usr/local/bin/can_link_test --gtest_filter='SocketCan.*' >/out/gtest.log 2>&1
status=$?
echo "can_link_test exit status ${status}"
exit "${status}"
