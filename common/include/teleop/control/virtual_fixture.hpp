#pragma once

#include <array>
#include <cmath>

#include "teleop/types.hpp"

namespace teleop::control {

/// One face of a forbidden region: the points p with n·p > offset are forbidden. `normal` is a unit vector in the
/// device's base frame (dimensionless), `offset_m` the signed distance of the plane from the origin along it.
struct FixturePlane {
  DofVector normal;
  double offset_m = 0.0;
};

/// The forbidden-region virtual fixture of Abbott & Okamura eq. 7, generalised to N-DOF as a set of half-spaces:
/// for every plane with penetration d = n·x - offset > 0 the fixture pushes back with K·d along -n; the forces of
/// all penetrated planes add. With one plane and n = +1 in 1-DOF this is exactly eq. 7 (F_VF = K·X for X > 0,
/// else 0). Unilateral: no force outside.
///
/// Sign: Output::force_N is the force ON the device, i.e. -F_VF of eqs. 8-9 (the laws subtract F_VF). In 1-DOF
/// with n = +1 and offset 0, force_N = -K·X for X > 0.
class ForbiddenRegionFixture {
 public:
  static constexpr int kMaxPlanes = 8;

  struct Config {
    int dof = 1;
    double stiffness_N_per_m = 0.0;  ///< K_iVF; 0 disables the fixture.
    int plane_count = 0;
    std::array<FixturePlane, kMaxPlanes> planes{};
    /// Run-time plane moves (docs/clutch.md, "Run-time commands"): the node slews a moved plane's offset at most
    /// this fast (m/s) and its normal at most `max_normal_rate_rad_per_s`; the fixture itself does not use them.
    double max_offset_rate_m_per_s = 0.01;
    double max_normal_rate_rad_per_s = 0.1;
  };

  struct Output {
    DofVector force_N;  ///< Force the fixture applies to the device, base frame (pushes out of the region).
    double max_penetration_m = 0.0;  ///< Largest penetration over the planes; 0 when outside.
  };

  /// A disabled 1-DOF fixture (no planes, zero stiffness).
  ForbiddenRegionFixture();
  /// Validates and stores the config (normals are normalised). Throws teleop::Error on a bad config (set-up only):
  /// dof out of 1..kMaxDof, stiffness not finite or < 0, plane_count out of 0..kMaxPlanes, a normal of the wrong
  /// size, non-finite or (near) zero, a non-finite offset, or a positive stiffness without any plane.
  explicit ForbiddenRegionFixture(const Config& config);

  /// The 1-DOF fixture of eq. 7 at X = 0 (forbidden X > 0) with stiffness K (N/m).
  static Config Eq7(double stiffness_N_per_m);
  /// A single half-space on one axis: forbidden where direction·x[axis] > direction·offset (direction = ±1).
  static Config HalfSpace(int dof, int axis, double offset_m, double direction, double stiffness_N_per_m);

  /// Fixture force for the measured position (m, base frame). Allocation-free. A position of the wrong size or
  /// with non-finite entries gives zero force (the law rejects such input before it gets here).
  [[nodiscard]] Output Step(const DofVector& position_m) const noexcept;

  const Config& config() const noexcept { return config_; }
  /// A run-time stiffness (a ramp step of a checked change, docs/clutch.md "Run-time commands"). Ignored when not
  /// finite, negative, or positive without a plane. Allocation-free.
  void SetStiffness(double stiffness_N_per_m) noexcept {
    if (!(stiffness_N_per_m >= 0.0) || !(stiffness_N_per_m < 1e300)) return;
    if (stiffness_N_per_m > 0.0 && config_.plane_count == 0) return;
    config_.stiffness_N_per_m = stiffness_N_per_m;
  }
  /// A run-time plane (a slew step of a plane move). Ignored unless `index` names a configured plane and `normal`
  /// is finite, of the fixture's dof and of unit length (within 1e-6), and `offset_m` finite. Allocation-free.
  void SetPlane(int index, const DofVector& normal, double offset_m) noexcept {
    if (index < 0 || index >= config_.plane_count || normal.size() != config_.dof || !normal.allFinite() ||
        !(std::abs(normal.norm() - 1.0) < 1e-6) || !std::isfinite(offset_m)) {
      return;
    }
    FixturePlane& plane = config_.planes[static_cast<std::size_t>(index)];
    plane.normal = normal;
    plane.offset_m = offset_m;
  }

 private:
  Config config_{};
};

}  // namespace teleop::control
