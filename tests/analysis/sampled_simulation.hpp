#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

#include "teleop/analysis/teleoperator_model.hpp"

namespace teleop::analysis::test {

/// An independent time-domain simulation of the same sampled system the analysis models, written from the paper's
/// equations and not from the state matrix: the continuous master+operator and slave dynamics (eqs. 2, 5, 6, 26)
/// integrated with classical RK4 in `substeps` steps per period under zero-order-held actuator forces, and the
/// controller of eqs. 8-9 (with F_e = 0) evaluated once per sample with the backward-difference velocity of eq. 20,
/// the optional first-order low-pass and the optional one-sample delay of the peer's data, or a fractional delay τ
/// (peer_delay_fraction): the force terms computed from the peer's sample act only τ after the sample, the previous
/// ones until then (the period is integrated in two pieces split at τ). Positions are relative
/// to the equilibrium (the dual system of §3.1), so the fixtures act as plain springs (eqs. 18-19).
class SampledSimulation {
 public:
  SampledSimulation(const SampledTeleoperator& system, const LawGains& gains, const HumanModel& human,
                    int substeps = 64)
      : system_(system), gains_(gains), human_(human), substeps_(substeps) {
    if (system_.unilateral) {  // the master renders nothing of the slave
      gains_.kpm_N_per_m = 0.0;
      gains_.kdm_Ns_per_m = 0.0;
    }
    const double t = system_.period_s();
    filter_ = system_.velocity_filter_hz > 0.0
                  ? 1.0 - std::exp(-2.0 * std::numbers::pi * system_.velocity_filter_hz * t)
                  : 1.0;
  }

  /// Initial perturbation from the equilibrium (m, m/s). The controller memory starts at rest at the same place.
  void Perturb(double xm_m, double xs_m) {
    xm_ = xm_m;
    xs_ = xs_m;
    xm_prev_ = xm_m;
    xs_prev_ = xs_m;
  }

  /// One sample period: sample, control, then integrate under the held forces.
  void Step() {
    const double t = system_.period_s();
    const double ym = (1.0 - filter_) * ym_prev_ + filter_ * (xm_ - xm_prev_) / t;
    const double ys = (1.0 - filter_) * ys_prev_ + filter_ * (xs_ - xs_prev_) / t;
    // Each side's view of its peer: the previous sample (a whole-sample delay) or this one, held back by τ.
    const bool master_delayed = system_.peer_delay_samples > 0;
    const bool slave_delayed = system_.slave_peer_delay_fraction ? false : master_delayed;
    const double xs_peer = master_delayed ? xs_prev_ : xs_;
    const double ys_peer = master_delayed ? ys_prev_ : ys;
    const double xm_peer = slave_delayed ? xm_prev_ : xm_;
    const double ym_peer = slave_delayed ? ym_prev_ : ym;
    const LawGains& g = gains_;
    // Eq. 8 (F_e = 0) and eq. 9, fixtures as springs about the equilibrium; the terms of the peer's data apart.
    const double f_am_local =
        g.kpm_N_per_m * xm_ + g.kdm_Ns_per_m * ym + g.kvm_Ns_per_m * ym + g.master_fixture_N_per_m * xm_;
    const double f_am_peer = -g.kpm_N_per_m * xs_peer - g.kdm_Ns_per_m * ys_peer;
    const double f_as_local =
        -g.kps_N_per_m * xs_ - g.kds_Ns_per_m * ys - g.kvs_Ns_per_m * ys - g.slave_fixture_N_per_m * xs_;
    const double f_as_peer = g.kps_N_per_m * xm_peer + g.kds_Ns_per_m * ym_peer;
    xm_prev_ = xm_;
    xs_prev_ = xs_;
    ym_prev_ = ym;
    ys_prev_ = ys;

    const double tau_m = master_delayed ? 0.0 : std::clamp(system_.peer_delay_fraction, 0.0, 1.0) * t;
    const double tau_s =
        system_.slave_peer_delay_fraction ? std::clamp(*system_.slave_peer_delay_fraction, 0.0, 1.0) * t : tau_m;
    // [0, τ): the previous peer terms still act; [τ, T): the new ones. The two devices are coupled only through
    // the sampled forces, so each is integrated over the period with its own split.
    const double xs_start = xs_;
    const double vs_start = vs_;
    Integrate(tau_m, Steps(tau_m, true), f_am_local + f_am_peer_prev_, 0.0);
    Integrate(t - tau_m, Steps(tau_m, false), f_am_local + f_am_peer, 0.0);
    const double xm_end = xm_;
    const double vm_end = vm_;
    xs_ = xs_start;
    vs_ = vs_start;
    Integrate(tau_s, Steps(tau_s, true), 0.0, f_as_local + f_as_peer_prev_);
    Integrate(t - tau_s, Steps(tau_s, false), 0.0, f_as_local + f_as_peer);
    xm_ = xm_end;
    vm_ = vm_end;
    f_am_peer_prev_ = f_am_peer;
    f_as_peer_prev_ = f_as_peer;
  }

  double master_position_m() const { return xm_; }
  double slave_position_m() const { return xs_; }
  /// A norm of the state that sees every mode: positions and velocities scaled by the period.
  double Magnitude() const {
    const double t = system_.period_s();
    return std::abs(xm_) + std::abs(xs_) + t * (std::abs(vm_) + std::abs(vs_));
  }

 private:
  // Substeps of the piece before (early) or after τ, shared in proportion.
  int Steps(double tau_s, bool early) const {
    const double t = system_.period_s();
    const int early_steps = tau_s > 0.0 ? std::max(1, static_cast<int>(std::lround(substeps_ * tau_s / t))) : 0;
    if (early) return early_steps;
    return tau_s < t ? std::max(1, substeps_ - early_steps) : 0;
  }

  void Integrate(double duration_s, int steps, double f_am, double f_as) {
    if (steps <= 0 || duration_s <= 0.0) return;
    const double mm = system_.master.mass_kg + human_.mass_kg;
    const double bm = system_.master.damping_Ns_per_m + human_.damping_Ns_per_m;
    const double km = human_.stiffness_N_per_m;
    const double ms = system_.slave.mass_kg;
    const double bs = system_.slave.damping_Ns_per_m;
    // F_h* - F_am = Z_hm X_m around the equilibrium (F_h* constant); Z_s X_s = F_as.
    auto am = [&](double x, double v) { return (-f_am - bm * v - km * x) / mm; };
    auto as = [&](double v) { return (f_as - bs * v) / ms; };
    const double h = duration_s / steps;
    for (int i = 0; i < steps; ++i) {
      Rk4(xm_, vm_, h, [&](double x, double v) { return am(x, v); });
      Rk4(xs_, vs_, h, [&](double, double v) { return as(v); });
    }
  }

  template <typename Accel>
  static void Rk4(double& x, double& v, double h, Accel accel) {
    const double k1x = v;
    const double k1v = accel(x, v);
    const double k2x = v + 0.5 * h * k1v;
    const double k2v = accel(x + 0.5 * h * k1x, k2x);
    const double k3x = v + 0.5 * h * k2v;
    const double k3v = accel(x + 0.5 * h * k2x, k3x);
    const double k4x = v + h * k3v;
    const double k4v = accel(x + h * k3x, k4x);
    x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
    v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
  }

  SampledTeleoperator system_;
  LawGains gains_;
  HumanModel human_;
  int substeps_;
  double filter_ = 1.0;
  double xm_ = 0.0, vm_ = 0.0, xs_ = 0.0, vs_ = 0.0;
  double xm_prev_ = 0.0, xs_prev_ = 0.0, ym_prev_ = 0.0, ys_prev_ = 0.0;
  double f_am_peer_prev_ = 0.0, f_as_peer_prev_ = 0.0;  // peer terms of the last sample (fractional delay)
};

}  // namespace teleop::analysis::test
