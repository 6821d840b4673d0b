#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace teleop::analysis {

/// Which device's forbidden-region fixture is analysed (its stiffness is the quantity searched for).
enum class FixtureSide : std::uint8_t { kMaster = 0, kSlave = 1 };

inline const char* ToString(FixtureSide side) noexcept { return side == FixtureSide::kMaster ? "master" : "slave"; }

/// A device as a mass with viscous friction (Abbott & Okamura eqs. 5-6), along the fixture normal.
struct DeviceModel {
  double mass_kg = 0.0;
  double damping_Ns_per_m = 0.0;
};

/// The paper's §4.1 haptic paddles with Delrin caps, and the Velcro finger loop on the master.
inline constexpr DeviceModel kPaperMasterDevice{0.040, 0.41};
inline constexpr DeviceModel kPaperSlaveDevice{0.036, 0.49};

/// The operator as an LTI mass-spring-damper (eq. 2), rigidly attached to the master handle. `force_N` is the
/// nominal force level (F̄_h) the parameters belong to; it does not enter the dynamics around the equilibrium.
struct HumanModel {
  double mass_kg = 0.0;
  double damping_Ns_per_m = 0.0;
  double stiffness_N_per_m = 0.0;
  double force_N = 0.0;
};

/// The gains of the three-channel law (eqs. 8-9) and the two fixture stiffnesses (eq. 7). Unset gains are 0.
/// K_fm multiplies the environment force F_e, which is zero in the free-space case analysed (§3), so it never
/// changes the result; it is kept so a law's gains can be passed through unchanged.
struct LawGains {
  double kpm_N_per_m = 0.0;             ///< K_pm
  double kps_N_per_m = 0.0;             ///< K_ps
  double kdm_Ns_per_m = 0.0;            ///< K_dm
  double kds_Ns_per_m = 0.0;            ///< K_ds
  double kvm_Ns_per_m = 0.0;            ///< K_vm (damping on the master's own velocity)
  double kvs_Ns_per_m = 0.0;            ///< K_vs (damping on the slave's own velocity)
  double kfm = 0.0;                     ///< K_fm (dimensionless; drops out, F_e = 0)
  double master_fixture_N_per_m = 0.0;  ///< K_mVF
  double slave_fixture_N_per_m = 0.0;   ///< K_sVF

  /// Symmetric position-position law of the paper's §4.3: K_pm = K_ps = kp, K_dm = K_ds = kd, the rest 0.
  static LawGains Symmetric(double kp_N_per_m, double kd_Ns_per_m) noexcept {
    LawGains g;
    g.kpm_N_per_m = g.kps_N_per_m = kp_N_per_m;
    g.kdm_Ns_per_m = g.kds_Ns_per_m = kd_Ns_per_m;
    return g;
  }
  double& fixture(FixtureSide side) noexcept {
    return side == FixtureSide::kMaster ? master_fixture_N_per_m : slave_fixture_N_per_m;
  }
  double fixture(FixtureSide side) const noexcept {
    return side == FixtureSide::kMaster ? master_fixture_N_per_m : slave_fixture_N_per_m;
  }
};

/// Everything the analysis needs to know about the sampled teleoperator except the operator: both devices, the
/// law, the sampling rate and how the controller sees its data.
///
/// `peer_delay_samples`: 0 is the paper's model (both halves of the law see the same samples X_m(k), X_s(k));
/// 1 is what the two processes do over a link: each side's law at sample k uses the peer's position and velocity
/// from sample k-1 (the sample that arrived during the last period). The processes' start-up check uses 1 plus the
/// link's expected delay. Any d up to kMaxPeerDelaySamples: the law at sample k uses the peer's sample k-d (a link
/// across sites: 5-100 ms are 5-100 samples at 1 kHz); over one sample the model carries delay lines
/// (AssembleDelayedStateMatrix).
///
/// `peer_delay_fraction`: on top of the whole samples, the peer's sample reaches the law a further fraction τ/T of
/// a period late (the measured data age of a phase-locked pair), so the part of each actuator force computed from
/// peer data acts τ late: ZOH with a fractional input delay (Franklin, Powell & Workman §4.3.4). With 0 whole
/// samples, 0 is the paper's model and 1 the same as peer_delay_samples = 1; values between interpolate (see
/// docs/stability.md).
///
/// The two directions may differ: `peer_delay_samples` / `peer_delay_fraction` are what the master's law sees of
/// the slave (slave→master) and, unless the slave's own are set, also what the slave's law sees of the master.
/// `slave_peer_delay_samples` / `slave_peer_delay_fraction` (master→slave): when either is set, the slave's law sees
/// the master's sample that many whole samples plus that fraction late (an absent one of the two is 0). A triggered
/// pair (sync.mode triggered) sets only the fraction: the slave's cycle starts when the master's sample arrives,
/// while the master uses the reply at its next cycle (one sample). See PeerDelaysOf.
///
/// `unilateral`: the master actuator renders nothing of the slave (K_pm = K_dm = K_fm = 0; the master keeps K_vm and
/// its own fixture): §4.5, a haptic device against a virtual wall. The stiffness search for the slave side (§4.4,
/// master actuator saturated) also drops K_vm and K_mVF, since a saturated actuator is entirely out of the loop
/// (see EffectiveGains).
/// The bound on the whole-sample peer delay of each direction: 250 samples (250 ms at 1 kHz). The model's state
/// dimension is 8 + (d_sm + [φ_sm > 0]) + (d_ms + [φ_ms > 0]) over one sample (≤ 510), and one eigenvalue problem
/// costs O(n³) (`analysis_benchmark`, docs/stability.md "Delays over one sample").
inline constexpr int kMaxPeerDelaySamples = 250;

struct SampledTeleoperator {
  DeviceModel master = kPaperMasterDevice;
  DeviceModel slave = kPaperSlaveDevice;
  LawGains gains{};
  double rate_hz = 1000.0;
  double velocity_filter_hz = 0.0;   ///< First-order low-pass on the backward-difference velocity; 0 = none.
  int peer_delay_samples = 0;        ///< 0 (paper), 1 (the processes over a link), .. kMaxPeerDelaySamples.
  double peer_delay_fraction = 0.0;  ///< 0..1 on top of the whole samples: peer data age / period.
  std::optional<double> slave_peer_delay_fraction;  ///< 0..1: the slave's own (see above).
  std::optional<int> slave_peer_delay_samples;      ///< 0..kMaxPeerDelaySamples: the slave's own (see above).
  bool unilateral = false;

  double period_s() const noexcept { return 1.0 / rate_hz; }
};

/// The peer data age of each direction as whole samples + a fraction of a period (resolved from the fields above).
struct PeerDelays {
  int slave_to_master_samples = 0;        ///< What the master's law sees of the slave: whole samples.
  double slave_to_master_fraction = 0.0;  ///< .. plus this fraction of a period.
  int master_to_slave_samples = 0;        ///< What the slave's law sees of the master.
  double master_to_slave_fraction = 0.0;
  double slave_to_master() const noexcept { return slave_to_master_samples + slave_to_master_fraction; }
  double master_to_slave() const noexcept { return master_to_slave_samples + master_to_slave_fraction; }
};
PeerDelays PeerDelaysOf(const SampledTeleoperator& system) noexcept;

/// Sets both directions' delays from data ages in samples (≥ 0; whole part + fraction): slave→master into
/// peer_delay_samples/fraction, master→slave into the slave's own fields.
void SetPeerDelays(SampledTeleoperator& system, double slave_to_master_samples, double master_to_slave_samples);

/// Adds a link's one-way delay (s, ≥ 0) to both directions on top of what `system` already has (the processes'
/// one sample: their data age is one period plus the link's delay). Throws teleop::Error beyond kMaxPeerDelaySamples.
void AddLinkDelay(SampledTeleoperator& system, double link_delay_s);

/// "peer delay 1 sample", or per direction when they differ or are not whole: "peer delay slave→master 41.3
/// samples, master→slave 41.3 samples".
std::string DescribePeerDelay(const SampledTeleoperator& system);

/// Checks ranges (masses > 0, damping ≥ 0, rate 1 Hz..1 MHz, filter ≥ 0 and below Nyquist, whole-sample delays
/// 0..kMaxPeerDelaySamples, delay fractions in 0..1, gains finite, fixture and position gains ≥ 0). Throws
/// teleop::Error naming the offending field and its value.
void Validate(const SampledTeleoperator& system);
/// Checks a human model (mass > 0, damping ≥ 0, stiffness ≥ 0, all finite); throws teleop::Error.
void Validate(const HumanModel& human);

/// The gains as the model uses them for the analysed side: with `unilateral`, K_pm = K_dm = K_fm = 0, and for the
/// slave side also K_vm = K_mVF = 0 (saturated master). Without `unilateral`, the gains unchanged.
LawGains EffectiveGains(const SampledTeleoperator& system, FixtureSide side) noexcept;

}  // namespace teleop::analysis
