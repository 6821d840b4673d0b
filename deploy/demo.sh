#!/usr/bin/env bash
# The demo on one machine, no hardware: teleop-slave and teleop-master on 127.0.0.1 over UDP at 1 kHz, each with
# its half of the loopback plant. The scripted operator pushes the master so that the slave meets its forbidden-region
# virtual fixture, holds, and pulls back (about 5 s). Prints both summaries; writes telemetry CSVs, JSON summaries
# and the PNGs of deploy/teleop-plot to build/demo/.
#   ./deploy/demo.sh            UDP link
#   ./deploy/demo.sh --can      the same over the emulated CAN bus (for hosts without SocketCAN)
#   ./deploy/demo.sh --device hybrid   the hybrid motor-brake master (simulated) with the loopback slave (docs/hybrid.md)
#   ./deploy/demo.sh --device cobot   a cobot master (Colgate et al., docs/cobot.md) with the loopback slave, 2 DOF
#   ./deploy/demo.sh --device arm     the stylus master (simulated, 3 joints) with the 7-joint slave arm stopping at a
#                                     plane fixture (docs/arms.md), 3 DOF; writes build/demo-arm/demo-arm.png
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

# The UDP configs authenticate the link with a pre-shared key (link.security.mode psk, docs/security.md). A fresh
# key for this run, made here (git does not keep file modes, so no key is committed): echoes its path.
demo_key() {
  local key="$1/teleop.key"
  rm -f "${key}"
  "${TELEOP_BUILD}/bin/teleop-keygen" "${key}" >/dev/null
  echo "${key}"
}

# A two-machine rig config (deploy/configs/<rig>/*-udp.yaml) for this one machine: its 10.77.0.x addresses become
# 127.0.0.1 (the ports differ per role) and the real-time settings are relaxed (no root needed).
one_machine_config() {
  sed -e 's/10\.77\.0\.[12]:/127.0.0.1:/' -e 's/^\(\s*fifo_priority:\)\s*[0-9]*/\1 0/' \
      -e 's/^\(\s*lock_memory:\)\s*[a-z]*/\1 false/' "$1" > "$2"
}

# ---- hybrid device block: master = simulated hybrid motor-brake rig, slave = loopback, 2 DOF, UDP, ~3 s ----
if [[ "${1:-}" == "--device" && "${2:-}" == "hybrid" ]]; then
  teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
  teleop::build --target teleop-master teleop-slave teleop_keygen
  out="${TELEOP_BUILD}/demo"
  mkdir -p "${out}"
  key=$(demo_key "${out}")
  one_machine_config "${TELEOP_ROOT}/deploy/configs/hybrid/master-udp.yaml" "${out}/hybrid-master.yaml"
  one_machine_config "${TELEOP_ROOT}/deploy/configs/hybrid/slave-udp.yaml" "${out}/hybrid-slave.yaml"
  "${TELEOP_BUILD}/bin/teleop-slave" --config "${out}/hybrid-slave.yaml" --duration 6 --key-file "${key}" \
    --summary-json "${out}/hybrid-slave-summary.json" --telemetry-csv "${out}/hybrid-slave.csv" \
    > "${out}/hybrid-slave.log" 2>&1 &
  hybrid_slave=$!
  trap 'kill "${hybrid_slave}" 2>/dev/null || true' EXIT
  sleep 0.3
  hybrid_rc=0
  "${TELEOP_BUILD}/bin/teleop-master" --config "${out}/hybrid-master.yaml" --duration 3 --key-file "${key}" \
    --summary-json "${out}/hybrid-master-summary.json" --telemetry-csv "${out}/hybrid-master.csv" \
    > "${out}/hybrid-master.log" 2>&1 || hybrid_rc=$?
  wait "${hybrid_slave}" || hybrid_rc=$?
  echo "==== hybrid master ===="; cat "${out}/hybrid-master.log"
  echo "==== loopback slave ===="; cat "${out}/hybrid-slave.log"
  # Columns by name (the header of the telemetry CSV, runtime/telemetry.cpp), never by number: the CSV grew
  # rendered_force_N_* columns once and a numbered plot silently showed them as the fixture share.
  # The script is kept beside the PNG (deploy/figures.sh checks its ranges and key: tests/deploy/figure_check.py).
  # Each process's time_s starts at its own start, the slave's about 0.3 s before the master's: the slave's trace is
  # put on the master's clock by the difference of the times at which each first reports engaged (3), which the two
  # reach within a round trip of each other.
  engaged_at() {
    awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
             $col["engagement"] == 3 { print $col["time_s"]; exit }' "$1"
  }
  shift_s=$(awk -v m="$(engaged_at "${out}/hybrid-master.csv")" -v s="$(engaged_at "${out}/hybrid-slave.csv")" \
    'BEGIN { print (m == "" || s == "") ? 0 : s - m }')
  {
    echo "master='${out}/hybrid-master.csv'; slave='${out}/hybrid-slave.csv'; png='${out}/demo-hybrid.png'"
    echo "slave_shift=${shift_s}"
    cat <<'GNUPLOT'
set terminal pngcairo size 1000,650 noenhanced font ",10"
set output png
set datafile separator ','
set multiplot layout 2,1 title 'hybrid master (y axis) with loopback slave'
set grid
# Keys to the right of the plots, never over the traces; both panels share the same margins so the time axes align.
set key outside right top vertical reverse Left
set lmargin 10
set rmargin 42
# The master's run (3 s); rows after it (a loaded machine runs a few ms over) and the slave's rows from before the
# master started (negative on the master clock) are left out.
set xrange [0:3]
set ylabel 'position y (mm)'
plot master using (column('time_s') <= 3 ? column('time_s') : 1/0):(1e3*column('position_m_1')) with lines lw 4 lc rgb '#9ad0f5' title 'master y', \
     slave using (column('time_s') >= slave_shift && column('time_s') - slave_shift <= 3 ? column('time_s') - slave_shift : 1/0):(1e3*column('position_m_1')) \
       with lines lw 1 lc rgb '#0072b2' title 'slave y (on the master clock)', \
     30 with lines dt 2 lc rgb 'red' title 'master fixture'
set ylabel 'force y (N)'
set xlabel 't (s)'
plot master using (column('time_s') <= 3 ? column('time_s') : 1/0):'command_N_1' with lines lw 3 lc rgb '#9ad0f5' title 'master command y (law + FRVF)', \
     master using (column('time_s') <= 3 ? column('time_s') : 1/0):'rendered_force_N_1' with lines lc rgb '#0072b2' title 'rendered y (motors + brakes)', \
     master using (column('time_s') <= 3 ? column('time_s') : 1/0):'fixture_force_N_1' with lines dt 2 lc rgb 'red' title 'fixture share y'
unset multiplot
GNUPLOT
  } > "${out}/demo-hybrid.gp"
  gnuplot "${out}/demo-hybrid.gp"
  echo "[demo] hybrid plot: ${out}/demo-hybrid.png"
  exit $(( hybrid_rc != 0 ))
fi
# ---- end of the hybrid device block ----

variant=udp
[[ "${1:-}" == "--can" ]] && variant=can

# ---- cobot master (docs/cobot.md): its own configs and plot; the rest of the script is the loopback demo.
if [[ "${1:-}" == "--device" && "${2:-}" == "cobot" ]]; then
  teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
  teleop::build --target teleop-master teleop-slave teleop_keygen
  out="${TELEOP_BUILD}/demo-cobot"
  mkdir -p "${out}"
  key=$(demo_key "${out}")
  one_machine_config "${TELEOP_ROOT}/deploy/configs/cobot/master-udp.yaml" "${out}/master.yaml"
  one_machine_config "${TELEOP_ROOT}/deploy/configs/cobot/slave-udp.yaml" "${out}/slave.yaml"
  echo "[demo] cobot master + loopback slave (UDP, 1 kHz, 2 DOF, ~5 s)"
  "${TELEOP_BUILD}/bin/teleop-slave" --config "${out}/slave.yaml" --duration 8 --key-file "${key}" \
    --summary-json "${out}/slave-summary.json" --telemetry-csv "${out}/slave.csv" > "${out}/slave.log" 2>&1 &
  cobot_slave_pid=$!
  sleep 0.3
  master_rc=0
  "${TELEOP_BUILD}/bin/teleop-master" --config "${out}/master.yaml" --duration 5 --key-file "${key}" \
    --summary-json "${out}/master-summary.json" --telemetry-csv "${out}/master.csv" > "${out}/master.log" 2>&1 ||
    master_rc=$?
  slave_rc=0
  wait "${cobot_slave_pid}" || slave_rc=$?
  echo "==== master ===="; cat "${out}/master.log"
  echo "==== slave ====";  cat "${out}/slave.log"
  {
    echo "master='${out}/master.csv'; slave='${out}/slave.csv'; png='${out}/demo-cobot.png'"
    cat <<'GNUPLOT'
set datafile separator ","
set terminal pngcairo size 1000,800 noenhanced font ",10"
set output png
set title "teleop demo --device cobot: cobot master (steered walls) with the loopback slave, 1 kHz UDP"
set xlabel "x (mm)"; set ylabel "y (mm)"; set grid; set key bottom left; set size ratio -1
set arrow from graph 0, first 80 to graph 1, first 80 nohead lw 3 lc rgb "red"
set arrow from first 500, graph 0 to first 500, graph 1 nohead lw 3 dt 2 lc rgb "black"
# The labels in empty space: under the fixture line where the master runs along it, left of the slave wall where the
# trajectories run down its right side.
set label "master fixture y > 80 mm (steered wall)" at first 160, first 62 tc rgb "red"
set label "slave wall x = 500 mm" at first 490, first -250 right tc rgb "black"
# The axes always hold both walls and the labels (two unseen points at the corners of the scripted path's box), so a
# run cut short on a loaded machine does not shrink them to its own extent and push the labels off the canvas.
$box << EOD
0,-480
560,100
EOD
plot master using (1e3*column("position_m_0")):(1e3*column("position_m_1")) with lines lw 2 title "cobot master", \
     slave using (1e3*column("position_m_0")):(1e3*column("position_m_1")) with lines lw 1 title "slave", \
     master every 250 using (1e3*column("position_m_0")):(1e3*column("position_m_1")):(2*column("force_sensor_N_0")):(2*column("force_sensor_N_1")) with vectors head filled lc rgb "dark-green" title "operator force (2 mm/N)", \
     $box using 1:2 with dots lc rgb "white" notitle
GNUPLOT
  } > "${out}/demo-cobot.gp"
  gnuplot "${out}/demo-cobot.gp"
  echo "[demo] telemetry: ${out}/master.csv ${out}/slave.csv"
  echo "[demo] plot:      ${out}/demo-cobot.png"
  exit $(( master_rc != 0 || slave_rc != 0 ))
fi
# ---- arm rig (docs/arms.md): deploy/configs/arm's stylus master and 7-joint slave, 3 DOF, UDP, ~10 s ----
if [[ "${1:-}" == "--device" && "${2:-}" == "arm" ]]; then
  teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
  teleop::build --target teleop-master teleop-slave teleop_keygen teleop_arm
  out="${TELEOP_BUILD}/demo-arm"
  mkdir -p "${out}"
  key=$(demo_key "${out}")
  # The rig's configs with their URDFs named absolutely (they name ../../robots/ beside deploy/configs/arm) and the
  # real-time settings relaxed; the telemetry goes to the command line's --telemetry-csv.
  for role in master slave; do
    sed -e "s|^\(\s*urdf:\s*\)\.\./\.\./robots/|\1${TELEOP_ROOT}/deploy/robots/|" \
        -e 's/^\(\s*fifo_priority:\)\s*[0-9]*/\1 0/' -e 's/^\(\s*lock_memory:\)\s*[a-z]*/\1 false/' \
        "${TELEOP_ROOT}/deploy/configs/arm/${role}-stylus.yaml" > "${out}/${role}.yaml"
  done
  echo "[demo] stylus master + 7-joint slave arm (UDP, 1 kHz, 3 DOF, ~10 s: the slave's start-up check sweeps the arm)"
  "${TELEOP_BUILD}/bin/teleop-slave" --config "${out}/slave.yaml" --duration 6 --key-file "${key}" \
    --summary-json "${out}/slave-summary.json" --telemetry-csv "${out}/slave.csv" > "${out}/slave.log" 2>&1 &
  arm_slave_pid=$!
  trap 'kill "${arm_slave_pid}" 2>/dev/null || true' EXIT
  # The slave's start-up check sweeps the arm's configurations near the plane (about 2 s, docs/arms.md,
  # "Stability"); the master starts once it is done, so that the pair engages before the operator pushes (0.5 s).
  for _ in $(seq 300); do
    grep -q "stability check" "${out}/slave.log" 2>/dev/null && break
    kill -0 "${arm_slave_pid}" 2>/dev/null || break
    sleep 0.1
  done
  master_rc=0
  "${TELEOP_BUILD}/bin/teleop-master" --config "${out}/master.yaml" --duration 4 --key-file "${key}" \
    --summary-json "${out}/master-summary.json" --telemetry-csv "${out}/master.csv" > "${out}/master.log" 2>&1 ||
    master_rc=$?
  slave_rc=0
  wait "${arm_slave_pid}" || slave_rc=$?
  echo "==== stylus master ===="; cat "${out}/master.log"
  echo "==== 7-joint slave ===="; cat "${out}/slave.log"
  # Columns by name (the telemetry CSV's header, runtime/telemetry.cpp). The slave's joints where it rests on the
  # plane: its last engaged row; the fixture's predicted limit there from teleop-arm limit (the start-up check's
  # analysis at that one configuration, along the plane's normal -z).
  rest_q=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
                    $col["engagement"] == 3 { q = $col["joint_position_rad_0"];
                      for (j = 1; ("joint_position_rad_" j) in col; ++j) q = q "," $col["joint_position_rad_" j] }
                    END { print q }' "${out}/slave.csv")
  [[ -n "${rest_q}" ]] || { echo "[demo] the slave never engaged" >&2; exit 1; }
  "${TELEOP_BUILD}/bin/teleop-arm" limit --config "${out}/slave.yaml" --q "${rest_q}" --direction 0,0,-1 \
    > "${out}/limit.txt"
  limit=$(sed -n 's/^predicted limit of the slave fixture: \([0-9.]*\) N\/m.*/\1/p' "${out}/limit.txt")
  mass=$(sed -n 's/.*apparent mass \([0-9.]*\) kg.*/\1/p' "${out}/limit.txt")
  sweep=$(sed -n "s/.*over the arm's configurations: predicted limit \([0-9]*\) N\/m.*/\1/p" "${out}/slave.log")
  fixture=$(sed -n 's/^\s*stiffness_N_per_m:\s*\([0-9.]*\).*/\1/p' "${out}/slave.yaml" | head -n 1)
  penetration=$(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
                         { d = -0.03 - $col["position_m_2"]; if (d > m) m = d } END { printf "%.2f", 1e3 * m }' \
                "${out}/slave.csv")
  tracking=$(/usr/bin/python3 -c 'import json, sys
print("%.2f" % (1e3 * json.load(open(sys.argv[1]))["tracking_error_rms_m"]))' "${out}/slave-summary.json")
  summary="the slave's tool went ${penetration} mm through the plane; tracking error rms ${tracking} mm (slave summary)"
  echo "[demo] ${summary}"
  echo "[demo] fixture ${fixture} N/m; predicted limit at the slave's resting configuration ${limit%.*} N/m" \
       "(apparent mass $(printf "%.2f" "${mass}") kg along -z; teleop-arm limit --q ${rest_q}); over the configurations near the plane" \
       "(start-up sweep) ${sweep:-?} N/m"
  engaged_at() {
    awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
             $col["engagement"] == 3 { print $col["time_s"]; exit }' "$1"
  }
  shift_s=$(awk -v m="$(engaged_at "${out}/master.csv")" -v s="$(engaged_at "${out}/slave.csv")" \
    'BEGIN { print (m == "" || s == "") ? 0 : s - m }')
  # The script is kept beside the PNG (deploy/figures.sh checks its ranges and key: tests/deploy/figure_check.py).
  {
    echo "master='${out}/master.csv'; slave='${out}/slave.csv'; png='${out}/demo-arm.png'"
    echo "slave_shift=${shift_s}"
    printf 'limit_title="%s\\n%s"\n' \
      "fixture ${fixture} N/m at z = -30 mm; predicted stability limit at the slave's resting configuration: ${limit%.*} N/m" \
      "(apparent mass $(printf "%.2f" "${mass}") kg along -z: teleop-arm limit); near the plane, the start-up sweep's worst: ${sweep:-?} N/m"
    cat <<'GNUPLOT'
set terminal pngcairo size 1100,750 noenhanced font ",10"
set output png
set datafile separator ','
set multiplot layout 2,1 title "stylus master (3 joints) with the 7-joint slave arm, 1 kHz UDP: the slave stops at the plane fixture"
set grid
# Keys to the right of the plots, never over the traces; both panels share the same margins so the time axes align.
set key outside right top vertical reverse Left
set lmargin 10
set rmargin 34
# The master's run (4 s) on its clock; the slave's rows from before the master started are left out.
set xrange [0:4]
set title limit_title
set ylabel 'tool z (mm, from the working point)'
plot master using (column('time_s') <= 4 ? column('time_s') : 1/0):(1e3*column('position_m_2')) with lines lw 4 lc rgb '#9ad0f5' title 'master (stylus) z', \
     slave using (column('time_s') >= slave_shift && column('time_s') - slave_shift <= 4 ? column('time_s') - slave_shift : 1/0):(1e3*column('position_m_2')) \
       with lines lw 1.5 lc rgb '#0072b2' title 'slave (7 joints) z', \
     -30 with lines dt 2 lw 2 lc rgb 'red' title 'fixture plane'
unset title
set ylabel "slave joint position (rad)"
set xlabel 't (s, master clock)'
plot for [j=0:6] slave using (column('time_s') >= slave_shift && column('time_s') - slave_shift <= 4 ? column('time_s') - slave_shift : 1/0):(column(sprintf('joint_position_rad_%d', j))) \
       with lines lw 1.5 title sprintf('joint %d', j + 1)
unset multiplot
GNUPLOT
  } > "${out}/demo-arm.gp"
  gnuplot "${out}/demo-arm.gp"
  echo "[demo] telemetry: ${out}/master.csv ${out}/slave.csv (the slave's joint columns: joint_position_rad_*, joint_torque_Nm_*)"
  echo "[demo] plot:      ${out}/demo-arm.png"
  exit $(( master_rc != 0 || slave_rc != 0 ))
fi
teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build --target teleop-master teleop-slave teleop_keygen

out="${TELEOP_BUILD}/demo"
mkdir -p "${out}"
cfg="${TELEOP_ROOT}/deploy/configs"
master_cfg="${cfg}/master.yaml"
slave_cfg="${cfg}/slave.yaml"
key_args=(--key-file "$(demo_key "${out}")")  # UDP: authenticated; the CAN configs say mode insecure
pids=()
cleanup() { for p in "${pids[@]:-}"; do [[ -n "$p" ]] && kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT

if [[ "${variant}" == "can" ]]; then
  master_cfg="${cfg}/master-can.yaml"
  slave_cfg="${cfg}/slave-can.yaml"
  key_args=()
  teleop::build --target teleop-canbus
  "${TELEOP_BUILD}/bin/teleop-canbus" --port 47300 --bitrate 1000000 --duration-s 12 > "${out}/canbus.log" 2>&1 &
  pids+=($!)
  sleep 0.3
fi

echo "[demo] starting teleop-slave and teleop-master (${variant}, 1 kHz, loopback plant, ~5 s)"
"${TELEOP_BUILD}/bin/teleop-slave" --config "${slave_cfg}" --duration 8 "${key_args[@]}" \
  --summary-json "${out}/slave-summary.json" --telemetry-csv "${out}/slave.csv" > "${out}/slave.log" 2>&1 &
slave_pid=$!
pids+=("${slave_pid}")
sleep 0.3
master_rc=0
"${TELEOP_BUILD}/bin/teleop-master" --config "${master_cfg}" --duration 5 "${key_args[@]}" \
  --summary-json "${out}/master-summary.json" --telemetry-csv "${out}/master.csv" > "${out}/master.log" 2>&1 ||
  master_rc=$?
slave_rc=0
wait "${slave_pid}" || slave_rc=$?
cleanup  # the emulated bus daemon, if any
pids=()

echo
echo "==== master ===="; cat "${out}/master.log"
echo "==== slave ====";  cat "${out}/slave.log"

echo
"${TELEOP_ROOT}/deploy/teleop-plot" --title "demo (${variant}, 1 kHz)" --out "${out}" "${out}/master.csv" "${out}/slave.csv"
echo
echo "[demo] telemetry: ${out}/master.csv ${out}/slave.csv"
echo "[demo] summaries: ${out}/master-summary.json ${out}/slave-summary.json"
echo "[demo] plots:     ${out}/{master,slave}-{positions,forces,fixture,period,rtt,loss,engagement}.png (deploy/teleop-plot)"
exit $(( master_rc != 0 || slave_rc != 0 ))
