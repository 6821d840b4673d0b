#pragma once

#include <Eigen/Core>

#include "teleop/analysis/teleoperator_model.hpp"
#include "teleop/analysis/zero_order_hold.hpp"  // ZohBlock, DiscretizeMassSpringDamper (eq. 27)

namespace teleop::analysis {

/// Number of states of the discrete model (see StateMatrix).
inline constexpr int kModelStates = 8;

/// The closed-loop state transition x(k+1) = A·x(k) of the equilibrium dual system (Abbott & Okamura §3.1, eqs.
/// 15-19) sampled as in §3.2. State at sample k (SI units, positions along the fixture normal, relative to the
/// equilibrium):
///
///   x = [ x_m, v_m, x_s, v_s, X_m(k-1), X_s(k-1), y_m(k-1), y_s(k-1) ]
///
/// x_m, v_m: master+operator position and true velocity; x_s, v_s: slave; X_i(k-1): the previous position sample
/// (for the backward difference of eq. 20); y_i(k-1): the previous velocity estimate (for the low-pass and for the
/// peer's delayed velocity). Without filter and delay the last two states only produce two zero eigenvalues — the
/// paper's model also has eight eigenvalues, two of them identically zero. docs/stability.md derives every entry.
using StateMatrix = Eigen::Matrix<double, kModelStates, kModelStates>;

/// Master + operator (eq. 26: Z_hm = Z_h + Z_m) discretized; gamma_stale for the system's peer_delay_fraction.
ZohBlock DiscretizeMasterWithHuman(const SampledTeleoperator& system, const HumanModel& human) noexcept;
/// Slave (eq. 6) discretized; gamma_stale for the system's peer_delay_fraction.
ZohBlock DiscretizeSlave(const SampledTeleoperator& system) noexcept;

/// Assembles A from pre-discretized plant blocks and the law (eqs. 18-25), applying `unilateral` (K_pm = K_dm =
/// K_fm = 0). With peer_delay_fraction > 0 the peer-data terms of each actuator force are split over gamma and
/// gamma_stale of the blocks (the previous peer terms are rows over states the model already has: X(k-1), y(k-1);
/// no extra state is needed). Allocation-free; the stiffness search calls it for every operator at every step.
StateMatrix AssembleStateMatrix(const SampledTeleoperator& system, const ZohBlock& master_with_human,
                                const ZohBlock& slave) noexcept;

/// Validates `system` and `human` (throws teleop::Error) and returns A. Only for delays the 8 states model (each
/// direction 0 + a fraction, or exactly 1 sample: !NeedsDelayLines); throws otherwise.
StateMatrix BuildStateMatrix(const SampledTeleoperator& system, const HumanModel& human);

/// Whether a direction's delay is beyond what the 8 states model (more than one whole sample, or one and a fraction).
bool NeedsDelayLines(const SampledTeleoperator& system) noexcept;

/// The state dimension of the delay-line model: 8 + L_sm + L_ms, each line L = d + [φ > 0] (d whole samples, φ the
/// fraction of that direction, PeerDelaysOf).
int DelayedStateDimension(const SampledTeleoperator& system) noexcept;

/// The same closed loop with any delay: the 8 states above plus one delay line per direction holding the scalar
/// peer term of that side's law (-K_pm·X_s - K_dm·y_s for the master, K_ps·X_m + K_ds·y_m for the slave) of the last
/// L samples. The master's force at k uses the line's p(k-d) (and p(k-d-1) during the first φT of the period); the
/// line shifts by one each sample. For delays the 8 states model it has the same nonzero eigenvalues plus zeros
/// (tests/analysis/delay_line_test.cpp). Allocates (dynamic size).
Eigen::MatrixXd AssembleDelayedStateMatrix(const SampledTeleoperator& system, const ZohBlock& master_with_human,
                                           const ZohBlock& slave);
/// Validates and returns the delay-line model's A (any delay, also ≤ 1 sample).
Eigen::MatrixXd BuildDelayedStateMatrix(const SampledTeleoperator& system, const HumanModel& human);

/// Coefficient of the first-order velocity low-pass, a = 1 - exp(-2π·f_c·T); 1 when f_c = 0 (no filter). The same
/// discretization as control::VelocityEstimator.
double VelocityFilterCoefficient(double cutoff_hz, double period_s) noexcept;

}  // namespace teleop::analysis
