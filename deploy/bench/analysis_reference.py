#!/usr/bin/python3
"""An independent NumPy/SciPy implementation of the stability analysis (docs/stability.md) for deploy/bench.sh.

Builds the same 8-state closed-loop model of Abbott & Okamura §3 (ZOH plants by scipy.linalg.expm, eq. 20
backward-difference velocities, optional one-sample or fractional peer delay), evaluates all operators of the
default finger grid at once (stacked np.linalg.eigvals) and finds the largest stable fixture stiffness by bracketing
(x4 from 1000 N/m) and bisection to a relative tolerance of 1e-3, as teleop::analysis::FindMaxStableStiffness.
Prints JSON: the limits and the time each took, for comparison with teleop-analyze / analysis_benchmark.

  deploy/bench/analysis_reference.py [--repeat N]
"""
import argparse
import json
import time

import numpy as np
import scipy.linalg

# deploy/configs/human_bounds_finger.csv (the built-in default): force, m_min, m_max, b_min, b_max, k_min, k_max
FINGER_BOUNDS = [
    (2, 0.003, 0.009, 0.62, 1.86, 74, 230),
    (4, 0.003, 0.009, 0.74, 2.22, 98, 310),
    (6, 0.003, 0.009, 0.86, 2.58, 122, 390),
    (8, 0.003, 0.009, 0.98, 2.94, 146, 470),
    (11, 0.003, 0.009, 1.16, 3.48, 182, 590),
    (14, 0.003, 0.009, 1.34, 4.02, 218, 710),
    (17, 0.003, 0.009, 1.52, 4.56, 254, 830),
    (20, 0.003, 0.009, 1.70, 5.10, 290, 950),
]
MASTER = (0.040, 0.41)  # paper §4.1: mass kg, damping N·s/m
SLAVE = (0.036, 0.49)


def human_grid(steps=4):
    humans = []
    for _, m0, m1, b0, b1, k0, k1 in FINGER_BOUNDS:
        for m in np.linspace(m0, m1, steps):
            for b in np.linspace(b0, b1, steps):
                for k in np.linspace(k0, k1, steps):
                    humans.append((m, b, k))
    return np.array(humans)


def zoh(mass, damping, stiffness, period, delay=0.0):
    """phi, gamma over the period and gamma_stale = the part of gamma over the last `delay` of it."""
    a = np.array([[0.0, 1.0, 0.0], [-stiffness / mass, -damping / mass, 1.0 / mass], [0.0, 0.0, 0.0]])
    e = scipy.linalg.expm(a * period)
    phi, gamma = e[:2, :2], e[:2, 2]
    stale = np.zeros(2)
    if delay >= period:
        stale = gamma.copy()
    elif delay > 0.0:
        stale = gamma - scipy.linalg.expm(a * (period - delay))[:2, 2]
    return phi, gamma, stale


def prepare(rate, delay_samples, delay_fraction, humans):
    t = 1.0 / rate
    tau = 0.0 if delay_samples else delay_fraction * t
    masters = [zoh(MASTER[0] + m, MASTER[1] + b, k, t, tau) for m, b, k in humans]
    slave = zoh(SLAVE[0], SLAVE[1], 0.0, t, tau)
    return t, masters, slave


def state_matrices(t, masters, slave, gains, delay_samples):
    kp, kd, kvm, kvs, kmvf, ksvf = gains
    unit = np.eye(8)
    xm, xs, xmp, xsp, ymp, ysp = unit[0], unit[2], unit[4], unit[5], unit[6], unit[7]
    ym = (xm - xmp) / t
    ys = (xs - xsp) / t
    d = delay_samples > 0
    xs_m, ys_m = (xsp, ysp) if d else (xs, ys)
    xm_s, ym_s = (xmp, ymp) if d else (xm, ym)
    fam_local = (kp + kmvf) * xm + (kd + kvm) * ym
    fam_peer = -kp * xs_m - kd * ys_m
    fas_local = -(kp + ksvf) * xs - (kd + kvs) * ys
    fas_peer = kp * xm_s + kd * ym_s
    fam_prev = -kp * xsp - kd * ysp
    fas_prev = kp * xmp + kd * ymp
    base = np.zeros((8, 8))
    sphi, sgamma, sstale = slave
    base[2:4, 2:4] = sphi
    base[2:4] += np.outer(sgamma, fas_local + fas_peer)
    if not d:
        base[2:4] += np.outer(sstale, fas_prev - fas_peer)
    base[4], base[5], base[6], base[7] = xm, xs, ym, ys
    out = np.repeat(base[None], len(masters), axis=0)
    for i, (phi, gamma, stale) in enumerate(masters):
        out[i, 0:2, 0:2] = phi
        out[i, 0:2] -= np.outer(gamma, fam_local + fam_peer)
        if not d:
            out[i, 0:2] -= np.outer(stale, fam_prev - fam_peer)
    return out


def unstable(prepared, gains, delay_samples):
    t, masters, slave = prepared
    radius = np.abs(np.linalg.eigvals(state_matrices(t, masters, slave, gains, delay_samples))).max()
    return radius > 1.0 + 1e-9


def max_stiffness(side, rate=1000.0, kp=600.0, kd=2.0, delay_samples=0, delay_fraction=0.0, humans=None, tol=1e-3):
    humans = human_grid() if humans is None else humans
    prepared = prepare(rate, delay_samples, delay_fraction, humans)

    def gains(k):
        return (kp, kd, 0.0, 0.0, k if side == "master" else 0.0, k if side == "slave" else 0.0)

    lo, hi = 0.0, 1000.0
    if unstable(prepared, gains(hi), delay_samples):
        if unstable(prepared, gains(0.0), delay_samples):
            return 0.0
    else:
        while not unstable(prepared, gains(hi), delay_samples):
            lo, hi = hi, hi * 4.0
            if hi > 1e9:
                return 1e9
    while hi - lo > tol * max(lo, 1e-6):
        mid = 0.5 * (lo + hi)
        if unstable(prepared, gains(mid), delay_samples):
            hi = mid
        else:
            lo = mid
    return lo


def timed(fn, repeat):
    """Value, fastest wall time and fastest CPU time of this process (s) over `repeat` runs."""
    wall, cpu, value = None, None, None
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        value = fn()
        elapsed, elapsed_cpu = time.perf_counter() - start, time.process_time() - start_cpu
        wall = elapsed if wall is None else min(wall, elapsed)
        cpu = elapsed_cpu if cpu is None else min(cpu, elapsed_cpu)
    return value, wall, cpu


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs per figure; the fastest is reported")
    parser.add_argument("--quick", action="store_true", help="one limit, no curve (for bench.sh --smoke)")
    args = parser.parse_args()
    humans = human_grid()
    cases = [
        ("slave", 0, 0.0), ("master", 0, 0.0), ("slave", 1, 0.0), ("master", 1, 0.0),
        ("slave", 0, 0.05), ("slave", 0, 0.5), ("slave", 0, 1.0),
    ]
    if args.quick:
        cases = cases[:1]
    limits = []
    for side, samples, fraction in cases:
        value, seconds, cpu = timed(
            lambda: max_stiffness(side, delay_samples=samples, delay_fraction=fraction, humans=humans), args.repeat)
        limits.append({"side": side, "rate_hz": 1000.0, "kp": 600.0, "kd": 2.0, "peer_delay_samples": samples,
                       "peer_delay_fraction": fraction, "limit_N_per_m": value, "seconds": seconds,
                       "cpu_seconds": cpu})
    if args.quick:
        print(json.dumps({"operators": len(humans), "tolerance": 1e-3, "limits": limits}, indent=1))
        return
    rates = [250, 500, 750, 1000, 1250, 1500, 2000, 2500, 3000, 4000]
    curve, seconds, cpu = timed(lambda: [max_stiffness("slave", rate=r, humans=humans) for r in rates], args.repeat)
    print(json.dumps({"operators": len(humans), "tolerance": 1e-3, "limits": limits,
                      "fig7_curve": {"rates_hz": rates, "slave_limit_N_per_m": curve, "seconds": seconds,
                                     "cpu_seconds": cpu}},
                     indent=1))


if __name__ == "__main__":
    main()
