#!/usr/bin/env bash
# Brings a SocketCAN interface up for teleop-master/teleop-slave (docs/deployment.md, docs/quickstart.md):
# nominal bit rate, CAN FD data bit rate, automatic bus-off restart, transmit queue length. Then reads the settings
# back from the kernel and fails if they differ from what was asked.
#
#   sudo deploy/can-up.sh                                  # can0, 1 Mbit/s, FD 5 Mbit/s, restart-ms 100, txqueuelen 128
#   sudo deploy/can-up.sh --interface can1 --bitrate 500000 --dbitrate 2000000
#   sudo deploy/can-up.sh --no-fd --bitrate 1000000        # classic CAN
#   deploy/can-up.sh --dry-run                             # print the ip commands, touch nothing (no root needed)
#
# The bit rates must match link.can.nominal_bitrate_bit_per_s / data_bitrate_bit_per_s of both processes' configs
# and every other node on the bus. restart-ms: how long the controller waits after bus-off before it rejoins (the
# processes count bus-off and go to their safe state meanwhile; 0 = stay off until `ip link set can0 type can
# restart`). txqueuelen: frames the kernel queues before a send fails with ENOBUFS; a teleop cycle sends 1..5 frames
# per direction, so 128 is several cycles of slack without hiding a dead bus for long.
set -euo pipefail

interface=can0
bitrate=1000000
dbitrate=5000000
fd=on
restart_ms=100
txqueuelen=128
sample_point=""
dry_run=0

usage() { sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'; }
fail() { echo "can-up: $*" >&2; exit 2; }
need_int() {  # name value min max
  [[ "$2" =~ ^[0-9]+$ ]] || fail "$1 must be a whole number, got '$2'"
  (( $2 >= $3 && $2 <= $4 )) || fail "$1 must be in $3..$4, got $2"
}

while (( $# > 0 )); do
  case "$1" in
    --interface) interface="${2:?}"; shift 2 ;;
    --bitrate) bitrate="${2:?}"; shift 2 ;;
    --dbitrate) dbitrate="${2:?}"; shift 2 ;;
    --no-fd) fd=off; shift ;;
    --restart-ms) restart_ms="${2:?}"; shift 2 ;;
    --txqueuelen) txqueuelen="${2:?}"; shift 2 ;;
    --sample-point) sample_point="${2:?}"; shift 2 ;;
    --dry-run) dry_run=1; shift ;;
    -h | --help) usage; exit 0 ;;
    *) fail "unknown option '$1' (see --help)" ;;
  esac
done

[[ "${interface}" =~ ^[A-Za-z0-9_.-]{1,15}$ ]] || fail "--interface must be an interface name of 1..15 characters, got '${interface}'"
need_int --bitrate "${bitrate}" 10000 1000000
need_int --restart-ms "${restart_ms}" 0 60000
need_int --txqueuelen "${txqueuelen}" 1 100000
if [[ "${fd}" == on ]]; then
  need_int --dbitrate "${dbitrate}" 10000 12000000
  (( dbitrate >= bitrate )) || fail "--dbitrate (${dbitrate}) must not be below --bitrate (${bitrate})"
fi
if [[ -n "${sample_point}" ]]; then
  [[ "${sample_point}" =~ ^0\.[0-9]{1,3}$ ]] || fail "--sample-point must be like 0.875, got '${sample_point}'"
fi

type_args=(bitrate "${bitrate}")
[[ -n "${sample_point}" ]] && type_args+=(sample-point "${sample_point}")
if [[ "${fd}" == on ]]; then
  type_args+=(dbitrate "${dbitrate}" fd on)
else
  type_args+=(fd off)
fi
type_args+=(restart-ms "${restart_ms}")

commands=(
  "ip link set ${interface} down"
  "ip link set ${interface} type can ${type_args[*]}"
  "ip link set ${interface} txqueuelen ${txqueuelen}"
  "ip link set ${interface} up"
)

if (( dry_run )); then
  printf '%s\n' "${commands[@]}"
  exit 0
fi

command -v ip >/dev/null || fail "ip (iproute2) is not installed: apt-get install iproute2"
[[ $(id -u) -eq 0 ]] || fail "configuring ${interface} needs root (or CAP_NET_ADMIN): sudo $0 $*"
ip link show "${interface}" >/dev/null 2>&1 ||
  fail "no interface ${interface}: is the CAN adapter plugged in and its driver loaded? (ip link; dmesg | grep -i can)"
kind=$(ip -details -json link show "${interface}" | python3 -c 'import json,sys; print(json.load(sys.stdin)[0].get("linkinfo",{}).get("info_kind",""))')
[[ "${kind}" == can ]] ||
  fail "${interface} is of kind '${kind:-none}', not a CAN controller (a vcan has no bit rate: ip link set ${interface} up)"

for c in "${commands[@]}"; do
  echo "+ ${c}"
  # shellcheck disable=SC2086
  ${c} || fail "'${c}' failed; the controller may not support these settings (ip -details link show ${interface})"
done

# Read back what the kernel applied.
details=$(ip -details -json link show "${interface}")
read -r got_bitrate got_dbitrate got_restart got_qlen got_state < <(python3 -c '
import json, sys
d = json.loads(sys.argv[1])[0]
data = d.get("linkinfo", {}).get("info_data", {})
print(data.get("bittiming", {}).get("bitrate", 0), data.get("data_bittiming", {}).get("bitrate", 0),
      data.get("restart_ms", -1), d.get("txqlen", 0), data.get("state", "?"))' "${details}")
ok=1
[[ "${got_bitrate}" == "${bitrate}" ]] || { echo "can-up: bit rate is ${got_bitrate}, asked ${bitrate}" >&2; ok=0; }
if [[ "${fd}" == on && "${got_dbitrate}" != "${dbitrate}" ]]; then
  echo "can-up: data bit rate is ${got_dbitrate}, asked ${dbitrate}" >&2; ok=0
fi
[[ "${got_restart}" == "${restart_ms}" ]] || { echo "can-up: restart-ms is ${got_restart}, asked ${restart_ms}" >&2; ok=0; }
[[ "${got_qlen}" == "${txqueuelen}" ]] || { echo "can-up: txqueuelen is ${got_qlen}, asked ${txqueuelen}" >&2; ok=0; }
(( ok )) || exit 1
echo "can-up: ${interface} up: ${got_bitrate} bit/s, data ${got_dbitrate} bit/s (fd ${fd}), restart-ms ${got_restart}, txqueuelen ${got_qlen}, state ${got_state}"
