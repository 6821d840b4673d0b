#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// Geometry of the planar five-bar linkage of Kwon & Song (Fig. 1, Fig. 4), device base frame B: x to the right,
/// y away from the operator, origin midway between the two active joints. Active joint J1 sits at (+d, 0), J2 at
/// (−d, 0) with 2d = base_separation_m. Proximal link i (length proximal_i_m) turns with joint i; distal link i
/// (length distal_i_m) joins the end of proximal link i to the handle. Joint angles are measured from +x,
/// counter-clockwise. Paper defaults (§2.1): all links 200 mm, 2d = 0, J1 −40°…110°, J2 70°…220°, workspace
/// x −190…190 mm, y 90…320 mm.
struct FiveBarConfig {
  double proximal_1_m = 0.200;
  double proximal_2_m = 0.200;
  double distal_1_m = 0.200;
  double distal_2_m = 0.200;
  double base_separation_m = 0.0;
  double joint_1_min_rad = -40.0 * 3.14159265358979323846 / 180.0;
  double joint_1_max_rad = 110.0 * 3.14159265358979323846 / 180.0;
  double joint_2_min_rad = 70.0 * 3.14159265358979323846 / 180.0;
  double joint_2_max_rad = 220.0 * 3.14159265358979323846 / 180.0;
  /// The workspace the device is designed for (the rectangle of §2.1), base frame, m.
  double workspace_x_min_m = -0.190;
  double workspace_x_max_m = 0.190;
  double workspace_y_min_m = 0.090;
  double workspace_y_max_m = 0.320;

  /// Throws teleop::Error naming the first bad field (non-positive length, empty range, non-finite value).
  void Validate() const;
};

/// How far a configuration is from the two kinds of five-bar singularity, as sines of angles (1 best, 0 singular):
/// `parallel` between the two distal links (the handle loses stiffness), `serial_1`/`serial_2` between proximal and
/// distal link of each arm (an arm is stretched or folded). `min` is the smallest of the three.
struct SingularityMargin {
  double parallel = 0.0;
  double serial_1 = 0.0;
  double serial_2 = 0.0;
  double min = 0.0;
};

/// Kinematics of the five-bar: forward/inverse, Jacobian J = ∂p/∂q (m/rad), singularity margin. The assembly mode is
/// fixed to the paper's: the handle on the far side of the line between the elbows (for the default geometry the
/// linkage is a rhombus and p = l·(u(θ1) + u(θ2))), arm 1 elbow to the right of the base→handle line, arm 2 to the
/// left. All calls are real-time safe (no allocation, no exceptions).
class FiveBar {
 public:
  using Vector2 = Eigen::Vector2d;
  using Matrix2 = Eigen::Matrix2d;

  explicit FiveBar(const FiveBarConfig& config);  ///< Validates the config (teleop::Error).

  const FiveBarConfig& config() const noexcept { return config_; }

  /// Handle position p_B (m) for joint angles q = (θ1, θ2) (rad). False when the distal links cannot meet.
  [[nodiscard]] bool Forward(const Vector2& q_rad, Vector2& p_m) const noexcept;
  /// Joint angles for the handle at p_B, each wrapped into (the 2π window centred on) its joint range. False when
  /// p is out of reach of an arm. Joint limits are not checked here (see InJointLimits).
  [[nodiscard]] bool Inverse(const Vector2& p_m, Vector2& q_rad) const noexcept;
  /// Jacobian ṗ = J(q)·q̇ (m/rad) at q; false when q is not assembled or at a parallel singularity.
  [[nodiscard]] bool Jacobian(const Vector2& q_rad, Matrix2& jacobian_m_per_rad) const noexcept;
  [[nodiscard]] SingularityMargin Margin(const Vector2& q_rad) const noexcept;
  [[nodiscard]] bool InJointLimits(const Vector2& q_rad) const noexcept;
  /// Inside the design rectangle and reachable within the joint limits.
  [[nodiscard]] bool InWorkspace(const Vector2& p_m) const noexcept;

  Vector2 Base1() const noexcept { return {0.5 * config_.base_separation_m, 0.0}; }
  Vector2 Base2() const noexcept { return {-0.5 * config_.base_separation_m, 0.0}; }
  /// Elbow positions (the ends of the proximal links), m.
  Vector2 Elbow1(double theta_1_rad) const noexcept;
  Vector2 Elbow2(double theta_2_rad) const noexcept;

 private:
  FiveBarConfig config_;
};

}  // namespace teleop::device::hybrid
