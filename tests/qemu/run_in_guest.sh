#!/usr/bin/env bash
# Runs a script inside a qemu guest that has a real Linux SocketCAN bus (vcan0 up), and collects its outputs.
#
#   tests/qemu/run_in_guest.sh --out DIR [--timeout S] [--smp N] [--cache DIR]
#                              [--bin PATH[:GUEST_PATH]]... [--file PATH:GUEST_PATH]... -- GUEST_SCRIPT [ARGS...]
#
#   --out      results folder on the host, emptied first (a non-empty folder it did not create is refused). The guest sees it as /out (its working directory) and
#              writes there; the runner adds console.log (the whole serial console), guest.log (the script's output),
#              guest_status and timing.env (boot_s, total_s, accel).
#   --timeout  wall-clock limit of the whole guest, boot included (default 90 s). The script gets what is left after
#              boot, less 12 s; qemu is killed at the limit.
#   --bin      an executable to put in the guest, with every shared library `ldd` lists (default /usr/bin/<name>).
#   --file     any other file (config, data) to put in the guest at GUEST_PATH.
#   Environment: TELEOP_QEMU_ACCEL=kvm|tcg (default: KVM when a probe boots with it), TELEOP_QEMU_SHARE=console
#   (results through the console instead of 9p), TELEOP_QEMU_CACHE (see --cache).
#   --cache    where the Debian kernel is cached (default $TELEOP_QEMU_CACHE or ~/.cache/teleop/qemu).
#   GUEST_SCRIPT runs under busybox sh in the guest with OUT=/out, CAN_IFACE=vcan0, candump/cansend/cangen on PATH.
#
# Exit status: the guest script's; 124 when the guest ran out of time; 125 when the guest could not set up (module,
# vcan); 77 (ctest SKIP_RETURN_CODE) only when qemu cannot run at all: no qemu-system-x86_64, or no Debian kernel
# package reachable and none cached. Uses KVM when /dev/kvm is usable, TCG otherwise.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "${here}/../.." && pwd)"
out="" timeout_s=90 smp=2
cache_dir="${TELEOP_QEMU_CACHE:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/teleop/qemu}"
bin_args=() file_args=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --timeout) timeout_s="$2"; shift 2 ;;
    --smp) smp="$2"; shift 2 ;;
    --cache) cache_dir="$2"; shift 2 ;;
    --bin) bin_args+=(--bin "$2"); shift 2 ;;
    --file) file_args+=(--file "$2"); shift 2 ;;
    --) shift; break ;;
    -h | --help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    *) echo "run_in_guest.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
log() { echo "[run_in_guest] $*" >&2; }
[[ -n "${out}" ]] || { log "--out DIR is required"; exit 2; }
[[ $# -ge 1 && -f "$1" ]] || { log "the guest script (after --) is missing or not a file: '${1:-}'"; exit 2; }
[[ "${timeout_s}" =~ ^[0-9]+$ && "${timeout_s}" -ge 15 ]] || { log "--timeout must be a whole number >= 15 s"; exit 2; }
script="$1"
shift

start_ns=$(date +%s%N)
qemu="$(command -v qemu-system-x86_64 || true)"
if [[ -z "${qemu}" ]]; then
  log "SKIP: qemu-system-x86_64 not found (sudo apt-get install qemu-system-x86)"
  exit 77
fi

kernel_status=0
kernel_dir="$("${root}/deploy/qemu/fetch_kernel.sh" --cache "${cache_dir}")" || kernel_status=$?
if [[ ${kernel_status} -eq 77 ]]; then
  log "SKIP: no Debian kernel package reachable and none cached; the qemu guest cannot boot"
  exit 77
elif [[ ${kernel_status} -ne 0 ]]; then
  log "fetching the guest kernel failed (status ${kernel_status})"
  exit 1
fi

# Emptied first so that no stale result can pass a test; only a folder this runner made (marker file) or an empty
# one is ever deleted.
if [[ -d "${out}" && -n "$(ls -A "${out}")" && ! -f "${out}/.teleop-qemu-out" ]]; then
  log "--out ${out} is a non-empty folder this runner did not create; refusing to empty it"
  exit 2
fi
rm -rf "${out}"
mkdir -p "${out}"
out="$(cd "${out}" && pwd)"
touch "${out}/.teleop-qemu-out"
work="$(mktemp -d "${TMPDIR:-/tmp}/teleop-qemu.XXXXXX")"
trap 'rm -rf "${work}"' EXIT
echo "${timeout_s}" >"${work}/timeout_s"
printf '%s ' "$@" >"${work}/args"
"${root}/deploy/qemu/build_initramfs.sh" --kernel-dir "${kernel_dir}" --init "${here}/guest/init" \
  --out "${work}/initramfs.cpio" --file "${script}:/guest/script" --file "${work}/timeout_s:/guest/timeout_s" \
  --file "${work}/args:/guest/args" "${bin_args[@]}" "${file_args[@]}"

# KVM when it works. /dev/kvm can exist and still hang the guest (nested virtualisation in some CI VMs), so a 5 s
# probe boots the kernel with KVM and waits for its first message; the verdict is cached per host kernel and qemu
# version. TELEOP_QEMU_ACCEL=kvm|tcg forces a choice.
kvm_works() {
  [[ -r /dev/kvm && -w /dev/kvm ]] || return 1
  local verdict_file qemu_version
  qemu_version="$("${qemu}" --version | head -n 1 | awk '{print $4}')"
  verdict_file="${cache_dir}/kvm-probe-$(uname -r)-qemu-${qemu_version}"
  if [[ ! -f "${verdict_file}" ]]; then
    timeout --kill-after=2 5 "${qemu}" -accel kvm -cpu host -nographic -no-reboot -m 256M \
      -kernel "${kernel_dir}/vmlinuz" -append "console=ttyS0 earlyprintk=serial panic=-1" \
      </dev/null >"${work}/kvm-probe.log" 2>&1 || true
    if grep -q 'Linux version' "${work}/kvm-probe.log"; then echo ok >"${verdict_file}"; else echo hangs >"${verdict_file}"; fi
    log "KVM probe: $(cat "${verdict_file}") (cached in ${verdict_file})"
  fi
  [[ "$(cat "${verdict_file}")" == ok ]]
}
case "${TELEOP_QEMU_ACCEL:-auto}" in
  kvm) accel_name=kvm ;;
  tcg) accel_name=tcg ;;
  *) if kvm_works; then accel_name=kvm; else accel_name=tcg; fi ;;
esac
accel=(-accel tcg)
[[ "${accel_name}" == kvm ]] && accel=(-accel kvm -cpu host)
kernel_image="${kernel_dir}/vmlinuz"
[[ -f "${kernel_dir}/vmlinux" ]] && kernel_image="${kernel_dir}/vmlinux"  # PVH entry: no decompression under TCG

# Results come back through a 9p share of --out (virtio); without one (qemu built without virtfs, or
# TELEOP_QEMU_SHARE=console) the guest prints them on the console as a base64 tar.
share=(-virtfs "local,path=${out},mount_tag=out,security_model=none,id=out")
if [[ "${TELEOP_QEMU_SHARE:-9p}" == console ]] || ! "${qemu}" -device help 2>/dev/null | grep -q virtio-9p; then
  share=()
fi

run_qemu() {
  qemu_status=0
  boot_ns=$(date +%s%N)
  timeout --kill-after=5 "${timeout_s}" "${qemu}" "${accel[@]}" -nographic -no-reboot -m 512M -smp "${smp}" \
    -kernel "${kernel_image}" -initrd "${work}/initramfs.cpio" -nic none \
    -append "console=ttyS0 quiet panic=-1" \
    "${share[@]}" </dev/null >"${out}/console.log" 2>"${work}/qemu.err" || qemu_status=$?
}
run_qemu
if [[ ${qemu_status} -ne 0 && ${qemu_status} -ne 124 && "${kernel_image}" == */vmlinux ]] &&
  ! grep -q 'TELEOP-GUEST-READY' "${out}/console.log"; then
  log "qemu could not start the decompressed kernel ($(head -c 200 "${work}/qemu.err")); retrying with vmlinuz"
  kernel_image="${kernel_dir}/vmlinuz"
  run_qemu
fi
end_ns=$(date +%s%N)
tr -d '\r' <"${out}/console.log" >"${work}/console.txt"

# Results printed on the console (used when the 9p share could not be mounted).
if grep -q '^TELEOP-OUT-BEGIN' "${work}/console.txt"; then
  sed -n '/^TELEOP-OUT-BEGIN/,/^TELEOP-OUT-END/p' "${work}/console.txt" | sed '1d;$d' | base64 -d |
    tar -C "${out}" -xzf - || log "could not unpack the results the guest printed on the console"
fi

# Markers are searched anywhere in a line: the BIOS leaves escape sequences in front of the first one.
ready_line="$(grep -o -m1 'TELEOP-GUEST-READY .*' "${work}/console.txt" || true)"
exit_line="$(grep -o -m1 'TELEOP-GUEST-EXIT [0-9]*' "${work}/console.txt" || true)"
guest_boot_s="$(awk '{print $2}' <<<"${ready_line}")"
total_s="$(awk -v a="${start_ns}" -v b="${end_ns}" 'BEGIN { printf "%.2f", (b - a) / 1e9 }')"
qemu_s="$(awk -v a="${boot_ns}" -v b="${end_ns}" 'BEGIN { printf "%.2f", (b - a) / 1e9 }')"
{
  echo "accel=${accel_name}"
  echo "kernel=$(basename "${kernel_dir}")"
  echo "guest_boot_s=${guest_boot_s:-}"
  echo "qemu_s=${qemu_s}"
  echo "total_s=${total_s}"
} >"${out}/timing.env"
log "accel ${accel_name}, kernel $(basename "${kernel_dir}"): guest ready after ${guest_boot_s:-?} s of guest uptime;" \
  "qemu ran ${qemu_s} s; total ${total_s} s"

if grep -q 'TELEOP-GUEST-ERROR' "${work}/console.txt"; then
  log "guest set-up failed: $(grep -o -m1 'TELEOP-GUEST-ERROR.*' "${work}/console.txt" | cut -d' ' -f2-)"
fi
if [[ -z "${exit_line}" ]]; then
  if [[ ${qemu_status} -eq 124 || ${qemu_status} -eq 137 ]]; then
    log "FAIL: the guest did not finish within --timeout ${timeout_s} s; last console lines:"
    tail -n 20 "${work}/console.txt" >&2
    exit 124
  fi
  log "FAIL: qemu exited (status ${qemu_status}) without the guest's exit marker; qemu said:"
  cat "${work}/qemu.err" >&2
  tail -n 20 "${work}/console.txt" >&2
  exit 1
fi
status="$(awk '{print $2}' <<<"${exit_line}")"
[[ "${status}" =~ ^[0-9]+$ ]] || status=1
[[ ${status} -ne 0 ]] && log "guest script exited with status ${status}"
exit "${status}"
