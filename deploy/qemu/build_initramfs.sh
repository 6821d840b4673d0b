#!/usr/bin/env bash
# Builds the initramfs (an uncompressed newc cpio) for the qemu CAN guest.
#
#   deploy/qemu/build_initramfs.sh --kernel-dir DIR --init FILE --out FILE.cpio
#                                  [--bin PATH[:GUEST_PATH]]... [--file PATH:GUEST_PATH]...
#
#   --kernel-dir  a directory printed by fetch_kernel.sh (modules/ and modules.load are copied to /lib/teleop-modules)
#   --init        the guest's /init (tests/qemu/guest/init)
#   --bin         a dynamically or statically linked executable; it and every shared library `ldd` lists, plus the
#                 dynamic loader, are copied to the same paths in the guest. GUEST_PATH defaults to /usr/bin/<name>.
#   --file        any other file (guest script, config): copied to GUEST_PATH.
#
# busybox (static) provides the shell and the tools; candump, cansend and cangen from can-utils are always included.
set -euo pipefail

kernel_dir="" init="" out=""
bins=() files=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --kernel-dir) kernel_dir="$2"; shift 2 ;;
    --init) init="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --bin) bins+=("$2"); shift 2 ;;
    --file) files+=("$2"); shift 2 ;;
    -h | --help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    *) echo "build_initramfs.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

fail() { echo "[build_initramfs] $*" >&2; exit 1; }
[[ -f "${kernel_dir}/modules.load" ]] || fail "--kernel-dir '${kernel_dir}' has no modules.load (run fetch_kernel.sh)"
[[ -f "${init}" ]] || fail "--init '${init}' does not exist"
[[ -n "${out}" ]] || fail "--out is required"

busybox="$(command -v busybox || true)"
[[ -n "${busybox}" ]] || fail "busybox not found: sudo apt-get install busybox-static"
if ldd "${busybox}" >/dev/null 2>&1; then
  fail "${busybox} is dynamically linked: sudo apt-get install busybox-static"
fi
for tool in candump cansend cangen; do
  command -v "${tool}" >/dev/null || fail "${tool} not found: sudo apt-get install can-utils"
  bins+=("$(command -v "${tool}")")
done

root="$(mktemp -d "${TMPDIR:-/tmp}/teleop-initramfs.XXXXXX")"
trap 'rm -rf "${root}"' EXIT
mkdir -p "${root}"/{bin,sbin,usr/bin,usr/sbin,dev,proc,sys,tmp,run,out,etc,lib/teleop-modules,guest}
cp "${busybox}" "${root}/bin/busybox"
ln -s busybox "${root}/bin/sh"
cp "${init}" "${root}/init"
chmod 0755 "${root}/init"
cp "${kernel_dir}"/modules/*.ko "${kernel_dir}/modules.load" "${root}/lib/teleop-modules/"

# Copies a host file to the same path in the guest, following symlinks (the guest gets the real bytes).
copy_same_path() {
  local src="$1"
  [[ -e "${root}${src}" ]] && return 0
  mkdir -p "${root}$(dirname "${src}")"
  cp -L "${src}" "${root}${src}"
}

for spec in "${bins[@]}"; do
  src="${spec%%:*}"
  dest="/usr/bin/$(basename "${src}")"
  [[ "${spec}" == *:* ]] && dest="${spec#*:}"
  [[ -x "${src}" ]] || fail "--bin '${src}' is not an executable file"
  mkdir -p "${root}$(dirname "${dest}")"
  cp -L "${src}" "${root}${dest}"
  # "libfoo.so.1 => /lib/x86_64-linux-gnu/libfoo.so.1 (0x...)" and "/lib64/ld-linux-x86-64.so.2 (0x...)".
  if ldd_out="$(ldd "${src}" 2>/dev/null)"; then
    if grep -q 'not found' <<<"${ldd_out}"; then
      fail "${src}: missing shared libraries on the host: $(grep 'not found' <<<"${ldd_out}" | tr -s ' \t' ' ')"
    fi
    while read -r lib; do
      copy_same_path "${lib}"
    done < <(sed -n -e 's/.*=> \(\/[^ ]*\) .*/\1/p' -e 's/^[[:space:]]*\(\/[^ ]*\) (0x.*/\1/p' <<<"${ldd_out}")
  fi
done

for spec in "${files[@]}"; do
  [[ "${spec}" == *:* ]] || fail "--file '${spec}' must be HOST_PATH:GUEST_PATH"
  src="${spec%%:*}"
  dest="${spec#*:}"
  [[ -f "${src}" ]] || fail "--file '${src}' does not exist"
  mkdir -p "${root}$(dirname "${dest}")"
  cp -L "${src}" "${root}${dest}"
done

mkdir -p "$(dirname "${out}")"
(cd "${root}" && find . -print0 | cpio --null --create --format=newc --quiet) >"${out}"
