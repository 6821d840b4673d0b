#!/bin/sh
# ctest cia402_bringup_log2asc: can-utils' log2asc reads docs/cia402-bringup.log (candump -L format) and converts
# every frame to Vector ASC; the ASC file must hold as many frame lines as the log has lines.
#   check_log2asc.sh LOG2ASC LOG OUT.asc
set -eu
log2asc="$1"
log="$2"
out="$3"
"${log2asc}" -I "${log}" -O "${out}" vcan0
frames=$(wc -l <"${log}")
# ASC frame lines start with a time stamp and a channel number: "   0.000100 1  601  Tx  d 8 40 ...".
asc=$(grep -cE '^ *[0-9]+\.[0-9]+ +[0-9]+ +' "${out}" || true)
headers=$(grep -c '^date ' "${out}" || true)
last=$(grep -E '^ *[0-9]+\.[0-9]+ +[0-9]+ +' "${out}" | tail -n 1 | awk '{print $1}')
echo "log lines ${frames}, ASC frame lines ${asc}, ASC headers ${headers}, last ASC time ${last} s"
# One header, every frame converted, and relative times that run up to the log's length (not all 0).
[ "${frames}" -gt 0 ] && [ "${frames}" -eq "${asc}" ] && [ "${headers}" -eq 1 ] &&
  awk -v t="${last}" 'BEGIN { exit !(t > 0.01) }'

