#include "teleop/control/virtual_fixture.hpp"

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

[[noreturn]] void Fail(const std::string& message) { throw Error("virtual fixture: " + message); }

}  // namespace

ForbiddenRegionFixture::ForbiddenRegionFixture() : ForbiddenRegionFixture(Config{}) {}

ForbiddenRegionFixture::ForbiddenRegionFixture(const Config& config) : config_(config) {
  if (config.dof < 1 || config.dof > kMaxDof) {
    Fail("dof " + std::to_string(config.dof) + " is out of range; use 1.." + std::to_string(kMaxDof));
  }
  if (!std::isfinite(config.stiffness_N_per_m) || config.stiffness_N_per_m < 0.0) {
    Fail("stiffness_N_per_m " + std::to_string(config.stiffness_N_per_m) + " must be finite and >= 0");
  }
  if (config.plane_count < 0 || config.plane_count > kMaxPlanes) {
    Fail("plane_count " + std::to_string(config.plane_count) + " is out of range; use 0.." +
         std::to_string(kMaxPlanes));
  }
  if (config.stiffness_N_per_m > 0.0 && config.plane_count == 0) {
    Fail("stiffness_N_per_m is " + std::to_string(config.stiffness_N_per_m) +
         " but no plane is given; add at least one plane or set the stiffness to 0");
  }
  for (int i = 0; i < config.plane_count; ++i) {
    FixturePlane& plane = config_.planes[static_cast<std::size_t>(i)];
    const std::string which = "plane " + std::to_string(i) + ": ";
    if (plane.normal.size() != config.dof) {
      Fail(which + "normal has " + std::to_string(plane.normal.size()) +
           " entries; it needs dof = " + std::to_string(config.dof));
    }
    if (!AllFinite(plane.normal)) Fail(which + "normal has a non-finite entry");
    const double norm = plane.normal.norm();
    if (norm < 1e-9) Fail(which + "normal is zero; give the outward direction of the forbidden region");
    plane.normal /= norm;
    if (!std::isfinite(plane.offset_m)) Fail(which + "offset_m must be finite");
  }
}

ForbiddenRegionFixture::Config ForbiddenRegionFixture::Eq7(double stiffness_N_per_m) {
  return HalfSpace(1, 0, 0.0, 1.0, stiffness_N_per_m);
}

ForbiddenRegionFixture::Config ForbiddenRegionFixture::HalfSpace(int dof, int axis, double offset_m, double direction,
                                                                 double stiffness_N_per_m) {
  if (dof < 1 || dof > kMaxDof) Fail("dof " + std::to_string(dof) + " is out of range");
  if (axis < 0 || axis >= dof) {
    Fail("axis " + std::to_string(axis) + " is out of range for dof " + std::to_string(dof));
  }
  if (direction != 1.0 && direction != -1.0) Fail("direction must be +1 or -1");
  Config config;
  config.dof = dof;
  config.stiffness_N_per_m = stiffness_N_per_m;
  config.plane_count = 1;
  config.planes[0].normal = DofVector::Zero(dof);
  config.planes[0].normal[axis] = direction;
  config.planes[0].offset_m = direction * offset_m;
  return config;
}

ForbiddenRegionFixture::Output ForbiddenRegionFixture::Step(const DofVector& position_m) const noexcept {
  Output out;
  out.force_N = DofVector::Zero(config_.dof);
  if (config_.stiffness_N_per_m <= 0.0 || position_m.size() != config_.dof || !AllFinite(position_m)) return out;
  for (int i = 0; i < config_.plane_count; ++i) {
    const FixturePlane& plane = config_.planes[static_cast<std::size_t>(i)];
    const double penetration_m = plane.normal.dot(position_m) - plane.offset_m;
    if (penetration_m > 0.0) {
      out.force_N -= (config_.stiffness_N_per_m * penetration_m) * plane.normal;
      if (penetration_m > out.max_penetration_m) out.max_penetration_m = penetration_m;
    }
  }
  return out;
}

}  // namespace teleop::control
