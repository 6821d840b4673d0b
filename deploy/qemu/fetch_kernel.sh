#!/usr/bin/env bash
# Resolves, downloads and caches a stock Debian kernel for the qemu CAN guest, and prints the directory that holds it.
#
#   deploy/qemu/fetch_kernel.sh [--cache DIR] [--modules "can can-raw vcan ..."]
#
# The kernel package is never installed: it is fetched with `apt-get download` and unpacked with `dpkg -x` into a
# scratch directory, from which only the kernel image and the closure of the requested modules (with their
# dependencies, decompressed, in load order) are kept:
#
#   DIR/<kernel-release>/vmlinuz        the kernel image
#   DIR/<kernel-release>/vmlinux        the same kernel decompressed, when it can boot that way (PVH): qemu starts it
#                                       directly, which saves the ~6 s that decompressing bzImage takes under TCG
#   DIR/<kernel-release>/modules/*.ko   the modules, uncompressed (busybox insmod does not read .ko.xz/.zst)
#   DIR/<kernel-release>/modules.load   their file names, dependencies first: insmod them in this order
#
# The version is resolved at run time from the `linux-image-amd64` metapackage (never hard-coded), so the script keeps
# working when the mirror moves on. When the mirror cannot be reached the newest cached kernel is used.
# Exit status: 0 and the directory on stdout; 77 when no kernel can be had at all (nothing cached, nothing reachable).
set -euo pipefail

cache="${TELEOP_QEMU_CACHE:-${XDG_CACHE_HOME:-${HOME:-/tmp}/.cache}/teleop/qemu}"
# can/can-raw/can-dev/vcan give a virtual CAN bus; 9p/9pnet_virtio/virtio_pci give the shared results folder.
modules="can can-raw can-dev vcan 9p 9pnet_virtio virtio_pci"

while [[ $# -gt 0 ]]; do
  case "$1" in
    --cache) cache="$2"; shift 2 ;;
    --modules) modules="$2"; shift 2 ;;
    -h | --help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
    *) echo "fetch_kernel.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

log() { echo "[fetch_kernel] $*" >&2; }

# Newest complete cached kernel directory, or nothing.
newest_cached() {
  local d best=""
  for d in "${cache}"/*/; do
    [[ -f "${d}complete" ]] && best="${d%/}"
  done
  [[ -n "${best}" ]] && echo "${best}"
  return 0
}

# Name of the versioned kernel package behind linux-image-amd64 (e.g. linux-image-6.1.0-56-amd64), or nothing.
resolve_package() {
  apt-cache depends linux-image-amd64 2>/dev/null |
    sed -n 's/^ *Depends: \(linux-image-[0-9][^ ]*-amd64\)$/\1/p' | grep -v -- '-unsigned' | head -n 1
}

mkdir -p "${cache}"
exec 9>"${cache}/.lock"
flock 9  # Two guests started at once (ctest --parallel) must not unpack into the same directory.

package="$(resolve_package || true)"
if [[ -z "${package}" && $(id -u) -eq 0 && -z "$(newest_cached)" ]]; then
  log "apt-cache knows no linux-image-amd64; running apt-get update once"
  apt-get update -qq >/dev/null 2>&1 || true
  package="$(resolve_package || true)"
fi
if [[ -z "${package}" ]]; then
  cached="$(newest_cached)"
  if [[ -n "${cached}" ]]; then
    log "cannot resolve linux-image-amd64 (offline?); using cached ${cached##*/}"
    echo "${cached}"
    exit 0
  fi
  log "no Debian kernel package reachable (apt-cache depends linux-image-amd64 gave nothing) and none cached in ${cache}"
  exit 77
fi

release="${package#linux-image-}"
target="${cache}/${release}"
if [[ -f "${target}/complete" ]]; then
  echo "${target}"
  exit 0
fi

scratch="$(mktemp -d "${cache}/.fetch.XXXXXX")"
trap 'rm -rf "${scratch}"' EXIT
log "downloading ${package}"
if ! (cd "${scratch}" && apt-get download "${package}" >/dev/null 2>"${scratch}/apt.err"); then
  sed 's/^/[fetch_kernel]   /' "${scratch}/apt.err" >&2
  cached="$(newest_cached)"
  if [[ -n "${cached}" ]]; then
    log "download failed; using cached ${cached##*/}"
    echo "${cached}"
    exit 0
  fi
  log "cannot download ${package} and no kernel is cached in ${cache}"
  exit 77
fi
dpkg -x "${scratch}"/"${package}"_*.deb "${scratch}/root"
moddir="${scratch}/root/lib/modules/${release}"
[[ -d "${moddir}" ]] || moddir="${scratch}/root/usr/lib/modules/${release}"
image="$(ls "${scratch}"/root/boot/vmlinuz-* 2>/dev/null | head -n 1 || true)"
if [[ -z "${image}" || ! -d "${moddir}" ]]; then
  log "${package} does not contain boot/vmlinuz-* and lib/modules/${release}: unexpected package layout"
  exit 1
fi

mkdir -p "${scratch}/out/modules"
cp "${image}" "${scratch}/out/vmlinuz"
[[ -f "${scratch}/root/boot/config-${release}" ]] && cp "${scratch}/root/boot/config-${release}" "${scratch}/out/config"

# Depth-first over `modinfo -F depends`, so that every module is listed after what it needs. A module built into the
# kernel (listed in modules.builtin) needs no file.
declare -A seen=()
order=()
find_module() { find "${moddir}" -regextype posix-extended -regex ".*/(${1//[-_]/[-_]})\.ko(\.xz|\.zst|\.gz)?" | head -n 1; }
visit() {
  local name="$1" file dep
  [[ -n "${seen[${name//-/_}]:-}" ]] && return 0
  seen[${name//-/_}]=1
  file="$(find_module "${name}")"
  if [[ -z "${file}" ]]; then
    if grep -Eq "/${name//[-_]/[-_]}\.ko$" "${moddir}/modules.builtin" 2>/dev/null; then
      return 0
    fi
    log "module ${name} is neither a file nor built into ${release}"
    exit 1
  fi
  for dep in $(modinfo -F depends "${file}" | tr ',' ' '); do
    visit "${dep}"
  done
  local base="${file##*/}"
  case "${base}" in
    *.ko.xz) xz -dc "${file}" >"${scratch}/out/modules/${base%.xz}"; base="${base%.xz}" ;;
    *.ko.zst) zstd -qdc "${file}" >"${scratch}/out/modules/${base%.zst}"; base="${base%.zst}" ;;
    *.ko.gz) gzip -dc "${file}" >"${scratch}/out/modules/${base%.gz}"; base="${base%.gz}" ;;
    *) cp "${file}" "${scratch}/out/modules/${base}" ;;
  esac
  order+=("${base}")
}
for m in ${modules}; do visit "${m}"; done
printf '%s\n' "${order[@]}" >"${scratch}/out/modules.load"
echo "${package}" >"${scratch}/out/package"

# bzImage = boot stub + compressed ELF kernel. With CONFIG_PVH=y, qemu -kernel boots the ELF itself.
if grep -q '^CONFIG_PVH=y' "${scratch}/out/config" 2>/dev/null; then
  for format in xz zstd gzip; do
    case "${format}" in
      xz) magic='\xfd7zXZ\x00'; decompress=(xz -dc --single-stream) ;;
      zstd) magic='\x28\xb5\x2f\xfd'; decompress=(zstd -qdc) ;;
      gzip) magic='\x1f\x8b\x08'; decompress=(gzip -dc) ;;
    esac
    offset="$(LC_ALL=C grep -aboP -m1 "${magic}" "${image}" | head -n 1 | cut -d: -f1 || true)"
    [[ -n "${offset}" ]] || continue
    tail -c +"$((offset + 1))" "${image}" | "${decompress[@]}" >"${scratch}/out/vmlinux" 2>/dev/null || true
    if [[ "$(head -c 4 "${scratch}/out/vmlinux" | od -An -tx1 | tr -d ' ')" == 7f454c46 ]]; then
      break
    fi
    rm -f "${scratch}/out/vmlinux"
  done
fi
touch "${scratch}/out/complete"

rm -rf "${target}"
mv "${scratch}/out" "${target}"
log "cached ${release} in ${target} ($(wc -l <"${target}/modules.load") modules)"
echo "${target}"
