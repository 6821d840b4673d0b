#!/bin/sh
# Guest half of qemu_socketcan_unit: the SocketCAN gtests of tests/can/can_socket_test.cpp, which skip on a host
# without AF_CAN, run here against the real kernel stack on vcan0. vcan0 is switched to CAN FD (MTU 72) and
# CAN_EXPECT_FD=1 tells the exchange test that an FD port that cannot be opened is a failure, not a skip.
set -u
iface="${CAN_IFACE:-vcan0}"
ip link set "${iface}" down && ip link set "${iface}" mtu 72 && ip link set "${iface}" up || exit 1
CAN_IFACE="${iface}" CAN_EXPECT_FD=1 /usr/local/bin/can_link_test --gtest_filter='SocketCan.*' >/out/gtest.log 2>&1
status=$?
echo "can_link_test exit status ${status}"
exit "${status}"
