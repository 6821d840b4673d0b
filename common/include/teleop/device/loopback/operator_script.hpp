#pragma once

#include <array>
#include <cstdint>

namespace teleop::device {

/// A scripted exogenous operator force F_h*(t) (Abbott & Okamura eq. 1), one segment after another; the force is
/// the sum of the active segments' contributions. All along one direction per segment.
///
/// A segment is active for t in [start_s, start_s + duration_s); duration_s = 0 means "until the end of the run"
/// (allowed for hold, step and sine; a ramp needs a duration > 0). Contributions while active:
///   hold:  the total force on the segment's axis just before start_s (the segments listed before it), kept;
///   step:  to_N;
///   ramp:  from_N + (to_N - from_N)·(t - start_s)/duration_s;
///   sine:  offset_N + amplitude_N·sin(2π·frequency_hz·(t - start_s)).
/// Example, "ramp 0→3 N over [0.5, 2) s, hold, ramp back to -1 N over [3, 4) s, hold": ramp{0.5, 1.5, 0, 3},
/// hold{2.0, 1.0}, ramp{3.0, 1.0, 3, -1}, hold{4.0, 0}.
/// The plant samples F_h* at the start of each period and holds it over the period (as the paper's model does).
struct OperatorSegment {
  enum class Kind : std::uint8_t { kHold, kStep, kRamp, kSine };
  Kind kind = Kind::kHold;
  double start_s = 0.0;
  double duration_s = 0.0;    ///< Segment is active for t in [start, start+duration); 0 = open-ended.
  double from_N = 0.0;        ///< Ramp start level.
  double to_N = 0.0;          ///< Step level or ramp end level.
  double amplitude_N = 0.0;   ///< Sine amplitude.
  double frequency_hz = 0.0;  ///< Sine frequency.
  double offset_N = 0.0;      ///< Sine offset.
  int axis = 0;               ///< Which DOF the segment drives.
};

/// The simulated operator on the master: an equilibrium-point mass–spring–damper (eqs. 1–2),
/// F_h = F_h*(t) - (m_h·ẍ + b_h·ẋ + k_h·x), rigidly attached to the handle (its mass adds to the device's).
/// The same m_h, b_h, k_h act on every DOF; x is measured from the plant's origin (the operator's rest point).
struct SimulatedOperatorConfig {
  bool enabled = false;
  double mass_kg = 0.0;
  double damping_Ns_per_m = 0.0;
  double stiffness_N_per_m = 0.0;
  static constexpr int kMaxSegments = 16;
  int segment_count = 0;
  std::array<OperatorSegment, kMaxSegments> segments{};
};

/// The script of a SimulatedOperatorConfig, evaluated: F_h*(t) per axis. Hold levels are computed once at
/// construction, so TargetForce is a short loop with no allocation.
class OperatorScript {
 public:
  /// No operator: F_h* = 0.
  OperatorScript() = default;
  /// Validates the operator (when enabled) for `dof`; throws teleop::Error "loopback plant: human.…" naming the field.
  OperatorScript(const SimulatedOperatorConfig& config, int dof);

  /// base_N + F_h*(time_s) on `axis` (N): the active segments' contributions added to base_N in script order.
  /// base_N alone when the operator is disabled.
  double TargetForce(int axis, double time_s, double base_N = 0.0) const noexcept;

 private:
  SimulatedOperatorConfig config_{};
  std::array<double, SimulatedOperatorConfig::kMaxSegments> hold_level_N_{};
};

}  // namespace teleop::device
