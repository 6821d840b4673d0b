#!/usr/bin/env bash
# Checks whether this host is ready to run teleop-master/teleop-slave in real time, and prints what to fix
# (docs/deployment.md, "Real-time host"). Reads only; changes nothing; no root needed.
#
#   deploy/rt-check.sh                 # this host, limits of this shell
#   deploy/rt-check.sh --cpu 3         # also: is CPU 3 (realtime.cpu) isolated and free of IRQs?
#   deploy/rt-check.sh --pid 1234      # limits of a running process (e.g. the service's)
#   deploy/rt-check.sh --root DIR      # read DIR/proc and DIR/sys instead (the tests use a fake host)
#
# Each finding is one line: "ok", "warn" (works, but jitter will be worse) or "FIX" followed by the command or
# setting that fixes it. Exit status: 0 when nothing needs fixing, 1 when something does, 2 on bad arguments.
set -uo pipefail

root=""
cpu=-1
pid=self
while (( $# > 0 )); do
  case "$1" in
    --root) root="${2:?}"; shift 2 ;;
    --cpu) cpu="${2:?}"; shift 2 ;;
    --pid) pid="${2:?}"; shift 2 ;;
    -h | --help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "rt-check: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ "${cpu}" =~ ^-?[0-9]+$ ]] || { echo "rt-check: --cpu must be a CPU number, got '${cpu}'" >&2; exit 2; }
[[ "${pid}" == self || "${pid}" =~ ^[0-9]+$ ]] || { echo "rt-check: --pid must be a process id, got '${pid}'" >&2; exit 2; }

fixes=0
warns=0
ok() { printf '  ok    %-16s %s\n' "$1" "$2"; }
warn() { printf '  warn  %-16s %s\n' "$1" "$2"; warns=$((warns + 1)); [[ -n "${3:-}" ]] && printf '        %-16s -> %s\n' "" "$3"; return 0; }
fix() { printf '  FIX   %-16s %s\n' "$1" "$2"; printf '        %-16s -> %s\n' "" "$3"; fixes=$((fixes + 1)); }
readf() { [[ -r "${root}$1" ]] && cat "${root}$1" 2>/dev/null; }

# Expands a CPU list such as "1-3,6" into "1 2 3 6".
expand_cpus() {
  local part out=() a b i
  IFS=',' read -ra parts <<<"$1"
  for part in "${parts[@]}"; do
    [[ -z "${part}" ]] && continue
    if [[ "${part}" == *-* ]]; then
      a=${part%-*}; b=${part#*-}
      for ((i = a; i <= b; i++)); do out+=("$i"); done
    else
      out+=("${part}")
    fi
  done
  echo "${out[@]:-}"
}

echo "rt-check: real-time readiness of $( [[ -n "${root}" ]] && echo "the host under ${root}" || cat /proc/sys/kernel/hostname 2>/dev/null )"
cmdline=$(readf /proc/cmdline)

# 1. Preemption model.
version=$(readf /proc/version)
if [[ "$(readf /sys/kernel/realtime)" == 1* ]] || [[ "${version}" == *PREEMPT_RT* ]]; then
  ok preemption "PREEMPT_RT kernel"
else
  dynamic=$(readf /sys/kernel/debug/sched/preempt)
  if [[ "${dynamic}" == *"(full)"* ]] || [[ "${cmdline}" == *preempt=full* ]]; then
    warn preemption "full preemption (PREEMPT_DYNAMIC), not PREEMPT_RT: worst-case latency in the 100 us range" \
      "for the lowest jitter install the RT kernel: apt-get install linux-image-rt-amd64"
  elif [[ "${version}" == *PREEMPT* ]]; then
    warn preemption "preemptible kernel ($(grep -o 'PREEMPT[A-Z_]*' <<<"${version}" | head -n 1)), not PREEMPT_RT" \
      "apt-get install linux-image-rt-amd64 (or boot with preempt=full)"
  else
    fix preemption "no kernel preemption: a 1 kHz loop will miss deadlines under load" \
      "apt-get install linux-image-rt-amd64 and reboot into it"
  fi
fi

# 2. CPU frequency governor.
governors=()
for g in "${root}"/sys/devices/system/cpu/cpu[0-9]*/cpufreq/scaling_governor; do
  [[ -r "$g" ]] && governors+=("$(basename "$(dirname "$(dirname "$g")")")=$(cat "$g")")
done
if (( ${#governors[@]} == 0 )); then
  ok governor "no cpufreq driver (fixed frequency or a VM): nothing to set"
else
  slow=()
  for entry in "${governors[@]}"; do [[ "${entry#*=}" == performance ]] || slow+=("${entry}"); done
  if (( ${#slow[@]} == 0 )); then
    ok governor "performance on all ${#governors[@]} CPUs"
  else
    fix governor "not 'performance': ${slow[*]}" \
      "cpupower frequency-set -g performance (package linux-cpupower), or write performance to /sys/devices/system/cpu/cpu*/cpufreq/scaling_governor"
  fi
fi

# 3 and 4. Limits of this shell (or --pid): real-time priority and locked memory.
limits=$(readf "/proc/${pid}/limits")
if [[ -z "${limits}" ]]; then
  warn limits "cannot read /proc/${pid}/limits"
else
  rtprio=$(awk '/^Max realtime priority/ {print $4}' <<<"${limits}")
  memlock=$(awk '/^Max locked memory/ {print $4}' <<<"${limits}")
  uid=$(awk '/^Uid:/ {print $2}' <<<"$(readf "/proc/${pid}/status")")
  if [[ "${uid}" == 0 ]]; then
    ok rtprio "root: SCHED_FIFO allowed (CAP_SYS_NICE) whatever the limit (${rtprio})"
  elif [[ "${rtprio}" == unlimited ]] || { [[ "${rtprio}" =~ ^[0-9]+$ ]] && (( rtprio >= 80 )); }; then
    ok rtprio "rtprio limit ${rtprio} (the rig configs use realtime.fifo_priority 80)"
  else
    fix rtprio "rtprio limit ${rtprio:-?}: realtime.fifo_priority 80 will be refused" \
      "LimitRTPRIO=90 in the unit (deploy/systemd/ has it), or '@teleop - rtprio 90' in /etc/security/limits.d/teleop.conf"
  fi
  if [[ "${uid}" == 0 ]]; then
    ok memlock "root: mlockall allowed (CAP_IPC_LOCK) whatever the limit (${memlock})"
  elif [[ "${memlock}" == unlimited ]]; then
    ok memlock "locked-memory limit unlimited"
  else
    fix memlock "locked-memory limit ${memlock:-?} bytes: realtime.lock_memory (mlockall) will fail" \
      "LimitMEMLOCK=infinity in the unit (deploy/systemd/ has it), or '@teleop - memlock unlimited' in /etc/security/limits.d/teleop.conf"
  fi
fi

# 5. Isolated CPUs.
isolated=$(readf /sys/devices/system/cpu/isolated)
isolated=${isolated//[[:space:]]/}
present=$(readf /sys/devices/system/cpu/present)
present=${present//[[:space:]]/}
isolated_list=$(expand_cpus "${isolated}")
if [[ -n "${isolated_list}" ]]; then
  nohz=$(grep -o 'nohz_full=[^ ]*' <<<"${cmdline}" || true)
  ok isolcpus "isolated CPUs ${isolated}${nohz:+ (${nohz})}: set realtime.cpu to one of them"
  if [[ "${cpu}" -ge 0 ]] && [[ " ${isolated_list} " != *" ${cpu} "* ]]; then
    fix isolcpus "realtime.cpu ${cpu} is not isolated (isolated: ${isolated})" \
      "pick one of ${isolated}, or add CPU ${cpu} to isolcpus= on the kernel command line"
  fi
else
  last=$(expand_cpus "${present:-0}"); last=${last##* }
  if [[ "${last}" == 0 ]]; then
    warn isolcpus "one CPU only: nothing to isolate; the loop shares it with everything else"
  else
    fix isolcpus "no isolated CPUs (CPUs ${present:-?}): the loop shares its CPU with every other task" \
      "add 'isolcpus=${last} nohz_full=${last} rcu_nocbs=${last}' to GRUB_CMDLINE_LINUX in /etc/default/grub, update-grub, reboot; then realtime.cpu: ${last}"
    [[ "${cpu}" -lt 0 ]] && cpu=${last}
  fi
fi

# 6. IRQ affinity: no device interrupt should land on the loop's CPU.
check_cpus=""
if [[ "${cpu}" -ge 0 ]]; then check_cpus="${cpu}"; else check_cpus="${isolated_list}"; fi
if [[ -z "${check_cpus}" ]]; then
  ok irq-affinity "no real-time CPU chosen (realtime.cpu -1): IRQ affinity not checked"
elif ! compgen -G "${root}/proc/irq/[0-9]*/smp_affinity_list" >/dev/null; then
  warn irq-affinity "cannot read /proc/irq/*/smp_affinity_list"
else
  hits=()
  for f in "${root}"/proc/irq/[0-9]*/smp_affinity_list; do
    irq=$(basename "$(dirname "$f")")
    cpus=" $(expand_cpus "$(tr -d '[:space:]' <"$f")") "
    for c in ${check_cpus}; do
      if [[ "${cpus}" == *" ${c} "* ]]; then hits+=("${irq}"); break; fi
    done
  done
  default_aff=$(readf /proc/irq/default_smp_affinity)
  if (( ${#hits[@]} == 0 )); then
    ok irq-affinity "no IRQ may run on CPU(s) ${check_cpus} (default mask ${default_aff:-?})"
  else
    shown="${hits[*]:0:12}"
    (( ${#hits[@]} > 12 )) && shown+=" ..."
    fix irq-affinity "${#hits[@]} IRQs may run on CPU(s) ${check_cpus}: ${shown}" \
      "for each: echo <other CPUs> > /proc/irq/<n>/smp_affinity_list; and IRQBALANCE_BANNED_CPULIST=${check_cpus// /,} in /etc/default/irqbalance (or irqaffinity= on the kernel command line)"
  fi
fi

# 7. Real-time throttling (informational: the kernel caps SCHED_FIFO at 95 % of each second by default).
rt_runtime=$(readf /proc/sys/kernel/sched_rt_runtime_us)
rt_runtime=${rt_runtime//[[:space:]]/}
if [[ -z "${rt_runtime}" ]]; then
  warn rt-throttling "cannot read /proc/sys/kernel/sched_rt_runtime_us"
elif [[ "${rt_runtime}" == -1 ]]; then
  warn rt-throttling "off (sched_rt_runtime_us = -1): a runaway SCHED_FIFO thread can lock a CPU up" \
    "sysctl kernel.sched_rt_runtime_us=950000 unless the loop's CPU is isolated"
else
  ok rt-throttling "SCHED_FIFO may use ${rt_runtime} us of every second (a 1 kHz loop needs a fraction)"
fi

# 8. Clock source.
clock=$(readf /sys/devices/system/clocksource/clocksource0/current_clocksource)
clock=${clock//[[:space:]]/}
if [[ -z "${clock}" ]]; then
  warn clocksource "cannot read the current clock source"
elif [[ "${clock}" == tsc || "${clock}" == arch_sys_counter ]]; then
  ok clocksource "${clock}"
else
  warn clocksource "${clock}: reading the clock is slower than with tsc" \
    "check dmesg for 'clocksource: tsc unstable'; in a VM this is expected"
fi

echo "rt-check: ${fixes} to fix, ${warns} warnings"
(( fixes == 0 ))
