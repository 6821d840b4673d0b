#include "teleop/analysis/discrete_model.hpp"

// Eigen's dynamic-size storage trips -Wnull-dereference in its own inlined zero-fill (GCC 12, -O3, the delay-line
// matrix); not ours to fix, as with Asio in transport/udp_link.cpp.
#pragma GCC diagnostic ignored "-Wnull-dereference"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

using Row = Eigen::Matrix<double, 1, kModelStates>;

// State indices (see StateMatrix); the velocities v_m = 1 and v_s = 3 only appear inside the plant blocks.
constexpr int kXm = 0;
constexpr int kXs = 2;
constexpr int kXmPrev = 4;
constexpr int kXsPrev = 5;
constexpr int kYmPrev = 6;
constexpr int kYsPrev = 7;

// Whether the master's law sees the slave's previous sample (a whole-sample delay, modelled by the rows).
bool MasterDelayed(const SampledTeleoperator& system) { return PeerDelaysOf(system).slave_to_master_samples > 0; }
// The same for the slave's law.
bool SlaveDelayed(const SampledTeleoperator& system) { return PeerDelaysOf(system).master_to_slave_samples > 0; }
// The fractional peer delay of each side in seconds (the part beyond the whole samples).
double MasterPeerDelay(const SampledTeleoperator& system) {
  return PeerDelaysOf(system).slave_to_master_fraction * system.period_s();
}
double SlavePeerDelay(const SampledTeleoperator& system) {
  return PeerDelaysOf(system).master_to_slave_fraction * system.period_s();
}

Row Unit(int i) {
  Row r = Row::Zero();
  r(i) = 1.0;
  return r;
}

// One delay line: the peer terms of one side's law, p(k-1) .. p(k-length), at states first .. first+length-1.
struct Line {
  int whole = 0;          // whole samples of delay
  bool fraction = false;  // a fraction on top: p(k-whole-1) also acts (Γ1)
  int first = 0;          // index of p(k-1)
  int length() const noexcept { return whole + (fraction ? 1 : 0); }
};

}  // namespace

bool NeedsDelayLines(const SampledTeleoperator& system) noexcept {
  const PeerDelays d = PeerDelaysOf(system);
  const auto beyond_rows = [](int whole, double fraction) { return whole > 1 || (whole == 1 && fraction > 0.0); };
  return beyond_rows(d.slave_to_master_samples, d.slave_to_master_fraction) ||
         beyond_rows(d.master_to_slave_samples, d.master_to_slave_fraction);
}

int DelayedStateDimension(const SampledTeleoperator& system) noexcept {
  const PeerDelays d = PeerDelaysOf(system);
  return kModelStates + d.slave_to_master_samples + (d.slave_to_master_fraction > 0.0 ? 1 : 0) +
         d.master_to_slave_samples + (d.master_to_slave_fraction > 0.0 ? 1 : 0);
}

Eigen::MatrixXd AssembleDelayedStateMatrix(const SampledTeleoperator& system, const ZohBlock& master_with_human,
                                           const ZohBlock& slave) {
  const PeerDelays d = PeerDelaysOf(system);
  const int n = DelayedStateDimension(system);
  const Line master_line{d.slave_to_master_samples, d.slave_to_master_fraction > 0.0, kModelStates};
  const Line slave_line{d.master_to_slave_samples, d.master_to_slave_fraction > 0.0,
                        kModelStates + master_line.length()};
  const double t = system.period_s();
  const double a = VelocityFilterCoefficient(system.velocity_filter_hz, t);
  LawGains g = system.gains;
  if (system.unilateral) {
    g.kpm_N_per_m = 0.0;
    g.kdm_Ns_per_m = 0.0;
    g.kfm = 0.0;
  }
  // Rows over the 8 base states, as in AssembleStateMatrix.
  const Row xm = Unit(kXm);
  const Row xs = Unit(kXs);
  const Row ym = (1.0 - a) * Unit(kYmPrev) + a * (Unit(kXm) - Unit(kXmPrev)) / t;
  const Row ys = (1.0 - a) * Unit(kYsPrev) + a * (Unit(kXs) - Unit(kXsPrev)) / t;
  // The peer terms of each law computed from this sample's peer data (what enters the line).
  const Row f_am_peer_now = -g.kpm_N_per_m * xs - g.kdm_Ns_per_m * ys;
  const Row f_as_peer_now = g.kps_N_per_m * xm + g.kds_Ns_per_m * ym;
  const Row f_am_local = (g.kpm_N_per_m + g.master_fixture_N_per_m) * xm + (g.kdm_Ns_per_m + g.kvm_Ns_per_m) * ym;
  const Row f_as_local = -(g.kps_N_per_m + g.slave_fixture_N_per_m) * xs - (g.kds_Ns_per_m + g.kvs_Ns_per_m) * ys;

  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
  // Adds sign·γ·(the peer term p(k-age)) to the two rows of a device: a base row for age 0, else a line state.
  const auto add_peer = [&m](int device, const Eigen::Vector2d& gamma, double sign, const Line& line, int age,
                             const Row& now) {
    if (age == 0) {
      m.block<2, kModelStates>(device, 0) += sign * gamma * now;
    } else {
      m.block<2, 1>(device, line.first + age - 1) += sign * gamma;
    }
  };
  // Master + operator: the local terms and the peer term of p(k-d); with a fraction, p(k-d-1) acts during the
  // first τ of the period instead (Γ1 = gamma_stale), as in AssembleStateMatrix.
  m.block<2, 2>(kXm, kXm) = master_with_human.phi;
  m.block<2, kModelStates>(kXm, 0) -= master_with_human.gamma * f_am_local;
  add_peer(kXm, master_with_human.gamma, -1.0, master_line, master_line.whole, f_am_peer_now);
  if (master_line.fraction) {
    add_peer(kXm, master_with_human.gamma_stale, -1.0, master_line, master_line.whole + 1, f_am_peer_now);
    add_peer(kXm, master_with_human.gamma_stale, +1.0, master_line, master_line.whole, f_am_peer_now);
  }
  m.block<2, 2>(kXs, kXs) = slave.phi;
  m.block<2, kModelStates>(kXs, 0) += slave.gamma * f_as_local;
  add_peer(kXs, slave.gamma, +1.0, slave_line, slave_line.whole, f_as_peer_now);
  if (slave_line.fraction) {
    add_peer(kXs, slave.gamma_stale, +1.0, slave_line, slave_line.whole + 1, f_as_peer_now);
    add_peer(kXs, slave.gamma_stale, -1.0, slave_line, slave_line.whole, f_as_peer_now);
  }
  m.block<1, kModelStates>(kXmPrev, 0) = xm;
  m.block<1, kModelStates>(kXsPrev, 0) = xs;
  m.block<1, kModelStates>(kYmPrev, 0) = ym;
  m.block<1, kModelStates>(kYsPrev, 0) = ys;
  // The lines shift by one sample: p(k) enters, the oldest drops out.
  const auto shift = [&m](const Line& line, const Row& now) {
    if (line.length() == 0) return;
    m.block<1, kModelStates>(line.first, 0) = now;
    for (int j = 1; j < line.length(); ++j) m(line.first + j, line.first + j - 1) = 1.0;
  };
  shift(master_line, f_am_peer_now);
  shift(slave_line, f_as_peer_now);
  return m;
}

Eigen::MatrixXd BuildDelayedStateMatrix(const SampledTeleoperator& system, const HumanModel& human) {
  Validate(system);
  Validate(human);
  return AssembleDelayedStateMatrix(system, DiscretizeMasterWithHuman(system, human), DiscretizeSlave(system));
}

double VelocityFilterCoefficient(double cutoff_hz, double period_s) noexcept {
  if (cutoff_hz <= 0.0) return 1.0;
  return 1.0 - std::exp(-2.0 * std::numbers::pi * cutoff_hz * period_s);
}

ZohBlock DiscretizeMasterWithHuman(const SampledTeleoperator& system, const HumanModel& human) noexcept {
  return DiscretizeMassSpringDamper(system.master.mass_kg + human.mass_kg,
                                    system.master.damping_Ns_per_m + human.damping_Ns_per_m, human.stiffness_N_per_m,
                                    system.period_s(), MasterPeerDelay(system));
}

ZohBlock DiscretizeSlave(const SampledTeleoperator& system) noexcept {
  return DiscretizeMassSpringDamper(system.slave.mass_kg, system.slave.damping_Ns_per_m, 0.0, system.period_s(),
                                    SlavePeerDelay(system));
}

StateMatrix AssembleStateMatrix(const SampledTeleoperator& system, const ZohBlock& master_with_human,
                                const ZohBlock& slave) noexcept {
  const double t = system.period_s();
  const double a = VelocityFilterCoefficient(system.velocity_filter_hz, t);
  const bool master_delayed = MasterDelayed(system);
  const bool slave_delayed = SlaveDelayed(system);
  LawGains g = system.gains;
  if (system.unilateral) {
    g.kpm_N_per_m = 0.0;
    g.kdm_Ns_per_m = 0.0;
    g.kfm = 0.0;
  }

  // Measurements and estimates at sample k as rows over the state: eq. 20 and the optional low-pass.
  const Row xm = Unit(kXm);
  const Row xs = Unit(kXs);
  const Row ym = (1.0 - a) * Unit(kYmPrev) + a * (Unit(kXm) - Unit(kXmPrev)) / t;
  const Row ys = (1.0 - a) * Unit(kYsPrev) + a * (Unit(kXs) - Unit(kXsPrev)) / t;
  // What each side's law sees of its peer: this sample, or the previous one over a link.
  const Row xs_seen_by_master = master_delayed ? Unit(kXsPrev) : xs;
  const Row ys_seen_by_master = master_delayed ? Unit(kYsPrev) : ys;
  const Row xm_seen_by_slave = slave_delayed ? Unit(kXmPrev) : xm;
  const Row ym_seen_by_slave = slave_delayed ? Unit(kYmPrev) : ym;

  // Eqs. 18-19 with the fixtures lumped into the local position gains (K_pmm = K_pm + K_mVF, K_pss = K_ps + K_sVF),
  // split into the part from local data and the part from peer data (which a fractional delay holds back).
  const Row f_am_local = (g.kpm_N_per_m + g.master_fixture_N_per_m) * xm + (g.kdm_Ns_per_m + g.kvm_Ns_per_m) * ym;
  const Row f_am_peer = -g.kpm_N_per_m * xs_seen_by_master - g.kdm_Ns_per_m * ys_seen_by_master;
  const Row f_as_local = -(g.kps_N_per_m + g.slave_fixture_N_per_m) * xs - (g.kds_Ns_per_m + g.kvs_Ns_per_m) * ys;
  const Row f_as_peer = g.kps_N_per_m * xm_seen_by_slave + g.kds_Ns_per_m * ym_seen_by_slave;
  // The peer terms of the previous sample, over the states that hold it (X(k-1), y(k-1)): used by gamma_stale.
  const Row f_am_peer_prev = -g.kpm_N_per_m * Unit(kXsPrev) - g.kdm_Ns_per_m * Unit(kYsPrev);
  const Row f_as_peer_prev = g.kps_N_per_m * Unit(kXmPrev) + g.kds_Ns_per_m * Unit(kYmPrev);

  StateMatrix a_matrix = StateMatrix::Zero();
  // Master + operator (eq. 16 with eq. 15 folded in, eq. 26): the actuator force opposes the operator.
  a_matrix.block<2, 2>(kXm, kXm) = master_with_human.phi;
  a_matrix.block<2, kModelStates>(kXm, 0) -= master_with_human.gamma * (f_am_local + f_am_peer);
  // Slave (eq. 17), free space.
  a_matrix.block<2, 2>(kXs, kXs) = slave.phi;
  a_matrix.block<2, kModelStates>(kXs, 0) += slave.gamma * (f_as_local + f_as_peer);
  // Fractional delay: during the first τ of the period the previous peer terms still act (Γ1), not the new ones.
  if (!master_delayed) {
    a_matrix.block<2, kModelStates>(kXm, 0) -= master_with_human.gamma_stale * (f_am_peer_prev - f_am_peer);
  }
  if (!slave_delayed) a_matrix.block<2, kModelStates>(kXs, 0) += slave.gamma_stale * (f_as_peer_prev - f_as_peer);
  // Shift registers.
  a_matrix.row(kXmPrev) = xm;
  a_matrix.row(kXsPrev) = xs;
  a_matrix.row(kYmPrev) = ym;
  a_matrix.row(kYsPrev) = ys;
  return a_matrix;
}

StateMatrix BuildStateMatrix(const SampledTeleoperator& system, const HumanModel& human) {
  Validate(system);
  Validate(human);
  if (NeedsDelayLines(system)) {
    throw Error("stability analysis: " + DescribePeerDelay(system) +
                " needs the delay-line model (BuildDelayedStateMatrix), not the 8-state one");
  }
  return AssembleStateMatrix(system, DiscretizeMasterWithHuman(system, human), DiscretizeSlave(system));
}

}  // namespace teleop::analysis
