#pragma once

// The setpoint stage of the coupling: applies the cycle's Changes (fixture stiffness, law gains, a fixture plane)
// at their bounded rates. Private to the node.

#include <array>

#include "changes.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/control/virtual_fixture.hpp"

namespace teleop::node {

/// Linear ramps of the fixture stiffness and the gains, and the plane's bounded slew (offset at a rate, normal
/// along the great circle at a rate). A change starts from what the law uses now; a later change of the same kind
/// replaces the one in progress. Allocation-free and noexcept in Step.
class Setpoints {
 public:
  struct Config {
    int dof = 1;
  };
  /// What crosses from one cycle to the next: the ramps and the slew in progress, and the largest plane steps.
  struct State {
    struct StiffnessRamp {
      bool active = false;
      double from_N_per_m = 0.0;
      double to_N_per_m = 0.0;
      double ramp_s = 0.0;
      double elapsed_s = 0.0;
    };
    struct GainRamp {
      bool active = false;
      double ramp_s = 0.0;
      double elapsed_s = 0.0;
      std::array<DofVector, 4> from;  ///< kp, kd, kv, kf at the start of the ramp.
      std::array<DofVector, 4> to;
    };
    struct PlaneSlew {
      bool active = false;
      int plane = 0;
      DofVector normal;  ///< The target (unit).
      double offset_m = 0.0;
      double offset_rate_m_per_s = 0.0;
      double normal_rate_rad_per_s = 0.0;
    };
    StiffnessRamp stiffness;
    GainRamp gains;
    PlaneSlew slew;
    double max_plane_offset_step_m = 0.0;    ///< Largest one-cycle change of a moved plane's offset so far.
    double max_plane_normal_step_rad = 0.0;  ///< ... and of its normal.
  };
  /// What the law is to use from this cycle on (each part only when its flag is set).
  struct Output {
    bool set_stiffness = false;
    double stiffness_N_per_m = 0.0;
    bool set_gains = false;
    std::array<DofVector, 4> gains;  ///< kp, kd, kv, kf.
    bool set_plane = false;
    int plane = 0;
    DofVector normal;  ///< Unit.
    double offset_m = 0.0;
  };

  explicit Setpoints(const Config& config);

  /// `law` and `fixture`: what the law uses now (the start of a new ramp or slew).
  Output Step(const Changes& changes, const control::ThreeChannelLaw::Config& law,
              const control::ForbiddenRegionFixture::Config& fixture, double period_s) noexcept;

  const State& state() const noexcept { return state_; }

 private:
  void Start(const Changes& changes, const control::ThreeChannelLaw::Config& law,
             const control::ForbiddenRegionFixture::Config& fixture) noexcept;
  void StepStiffness(double period_s, Output& out) noexcept;
  void StepGains(double period_s, Output& out) noexcept;
  void StepPlane(const control::FixturePlane& now, double period_s, Output& out) noexcept;

  Config config_;
  State state_;
};

}  // namespace teleop::node
