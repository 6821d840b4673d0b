#!/usr/bin/env bash
# Regenerates every figure of the gallery docs/figures.md into docs/figures/ (or --out DIR): the demo's PNGs
# (deploy/demo.sh: deploy/teleop-plot of both processes, the hybrid, cobot and arm device demos), `teleop-analyze sweep`
# and every `teleop-scenario` scenario with its defaults. About 60 s on 2 cores.
#   ./deploy/figures.sh                 into docs/figures/
#   ./deploy/figures.sh --out /tmp/fig  elsewhere (tests/deploy/figures_test.py)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/lib/common.sh"

out="${TELEOP_ROOT}/docs/figures"
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    *) echo "usage: $0 [--out DIR]" >&2; exit 2 ;;
  esac
done
mkdir -p "${out}"
out="$(cd "${out}" && pwd)"

teleop::ensure_packages "${TELEOP_PACKAGES[@]}"
teleop::build --target teleop-master teleop-slave teleop_keygen teleop-analyze teleop-scenario teleop_arm
bin="${TELEOP_BUILD}/bin"
work="${TELEOP_BUILD}/figures"
rm -rf "${work}"
mkdir -p "${work}"
rm -f "${out}"/*.png
# Each gnuplot figure's script, "<figure> <script>" a line: tests/deploy/figure_check.py checks that no panel's data
# reach outside its axes or lie under its key. (deploy/teleop-plot draws with matplotlib, autoscaled.)
scripts="${work}/gnuplot-scripts.txt"
: > "${scripts}"

# The demo (loopback plant, UDP, 1 kHz): deploy/teleop-plot's seven views of each process.
"${TELEOP_ROOT}/deploy/demo.sh" > "${work}/demo.log" 2>&1 || { tail -40 "${work}/demo.log"; exit 1; }
for f in "${TELEOP_BUILD}"/demo/{master,slave}-{positions,forces,fixture,period,rtt,loss,engagement}.png; do
  cp "${f}" "${out}/demo-$(basename "${f}")"
done
"${TELEOP_ROOT}/deploy/demo.sh" --device hybrid > "${work}/demo-hybrid.log" 2>&1 ||
  { tail -40 "${work}/demo-hybrid.log"; exit 1; }
cp "${TELEOP_BUILD}/demo/demo-hybrid.png" "${out}/demo-hybrid.png"
echo "demo-hybrid.png ${TELEOP_BUILD}/demo/demo-hybrid.gp" >> "${scripts}"
"${TELEOP_ROOT}/deploy/demo.sh" --device cobot > "${work}/demo-cobot.log" 2>&1 ||
  { tail -40 "${work}/demo-cobot.log"; exit 1; }
cp "${TELEOP_BUILD}/demo-cobot/demo-cobot.png" "${out}/demo-cobot.png"
echo "demo-cobot.png ${TELEOP_BUILD}/demo-cobot/demo-cobot.gp" >> "${scripts}"
# The arm rig (docs/arms.md): the stylus master and the 7-joint slave stopping at the plane, the predicted limit on it.
"${TELEOP_ROOT}/deploy/demo.sh" --device arm > "${work}/demo-arm.log" 2>&1 || { tail -40 "${work}/demo-arm.log"; exit 1; }
cp "${TELEOP_BUILD}/demo-arm/demo-arm.png" "${out}/demo-arm.png"
echo "demo-arm.png ${TELEOP_BUILD}/demo-arm/demo-arm.gp" >> "${scripts}"

# The stability analysis (docs/stability.md): the master fixture's limit against the rate and against K_p.
# The rate sweep is the paper's Fig. (no filter: a 200 Hz filter is above the Nyquist frequency at 250 Hz).
"${bin}/teleop-analyze" sweep --paper-model --side master --variable rate --values 250,500,1000,2000,4000 \
  --output "${work}/sweep-rate" > "${work}/sweep-rate.log"
"${bin}/teleop-analyze" sweep --side master --variable kp --kd 2 --rate 1000 --values 100,200,400,600,800,1000,1600,3200 \
  --output "${work}/sweep-kp" > "${work}/sweep-kp.log"
cp "${work}/sweep-rate.png" "${out}/analyze-sweep-rate.png"
cp "${work}/sweep-kp.png" "${out}/analyze-sweep-kp.png"
echo "analyze-sweep-rate.png ${work}/sweep-rate.png.gp" >> "${scripts}"
echo "analyze-sweep-kp.png ${work}/sweep-kp.png.gp" >> "${scripts}"
# The shipped pair's fixtures (deploy/configs/{slave,master}.yaml: K_p 600, K_d 2, 200 Hz filter, the master's peer
# fixture 2000 N/m) against the link's one-way delay on top of the pair's one sample (issue 32, docs/stability.md,
# "Delay"): 0 where the coupling itself is unstable.
delays=0,0.5,1,1.5,2,2.5,3,3.5,4,4.5,5,6,8,10
"${bin}/teleop-analyze" sweep --side slave --kp 600 --kd 2 --over delay --values "${delays}" \
  --output "${work}/sweep-delay-slave" > "${work}/sweep-delay-slave.log"
"${bin}/teleop-analyze" sweep --side master --kp 600 --kd 2 --other-fixture 2000 --over delay --values "${delays}" \
  --output "${work}/sweep-delay-master" > "${work}/sweep-delay-master.log"
for side in slave master; do
  cp "${work}/sweep-delay-${side}.png" "${out}/analyze-sweep-delay-${side}.png"
  echo "analyze-sweep-delay-${side}.png ${work}/sweep-delay-${side}.png.gp" >> "${scripts}"
done
# Softer coupling for a WAN (K_p 50, K_d 1: stable alone out to 100 ms; docs/link-emulation.md, "Setting a pair up
# for a WAN"), 8 operators (--human-steps 1: a few seconds; the 64 of the docs' table take about a minute).
"${bin}/teleop-analyze" sweep --side slave --kp 50 --kd 1 --human-steps 1 --over delay \
  --values 0,5,10,15,20,30,40,50,60,70,80,90,100 --output "${work}/sweep-delay-wan" > "${work}/sweep-delay-wan.log"
cp "${work}/sweep-delay-wan.png" "${out}/analyze-sweep-delay-wan.png"
echo "analyze-sweep-delay-wan.png ${work}/sweep-delay-wan.png.gp" >> "${scripts}"

# Every scenario with its defaults, in a directory of its own (each writes its PNG to the working directory).
table_only=(hybrid-table)
scenarios=$("${bin}/teleop-scenario" --help | sed -n 's/^  \([a-z][a-z-]*\)  .*/\1/p')
for s in ${scenarios}; do
  mkdir -p "${work}/${s}"
  (cd "${work}/${s}" && "${bin}/teleop-scenario" "${s}" > run.log 2>&1) || { tail -20 "${work}/${s}/run.log"; exit 1; }
  pngs=("${work}/${s}"/*.png)
  if [[ ! -f "${pngs[0]}" ]]; then
    # A scenario that only prints tables (hybrid-table: docs/hybrid.md) is named here; any other must draw.
    [[ " ${table_only[*]} " == *" ${s} "* ]] && continue
    echo "teleop-scenario ${s} wrote no PNG" >&2
    exit 1
  fi
  for p in "${pngs[@]}"; do
    name="scenario-$(basename "${p}" | tr '_' '-')"
    cp "${p}" "${out}/${name}"
    echo "${name} ${p%.png}.gp" >> "${scripts}"
  done
done

count=$(ls "${out}"/*.png | wc -l)
echo "[figures] ${count} PNGs, $(du -sk "${out}" | cut -f1) KiB in ${out} (gallery: docs/figures.md)"
