#include "teleop/device/law_command.hpp"

namespace teleop::device {

void FillCommand(const control::ThreeChannelLaw::Output& out, const control::ForbiddenRegionFixture& fixture,
                 const DofVector& position_m, Command& command) noexcept {
  command.force_N = out.command_N;
  command.fixture_force_N = out.fixture_force_N;
  const control::ForbiddenRegionFixture::Config& f = fixture.config();
  const bool enabled = f.stiffness_N_per_m > 0.0 && f.plane_count > 0;
  command.fixture_stiffness_N_per_m = enabled ? f.stiffness_N_per_m : 0.0;
  command.constraint_count = enabled ? f.plane_count : 0;
  const bool position_usable = position_m.size() == f.dof && AllFinite(position_m);
  for (int i = 0; i < command.constraint_count; ++i) {
    const control::FixturePlane& plane = f.planes[static_cast<std::size_t>(i)];
    Constraint& c = command.constraints[static_cast<std::size_t>(i)];
    c.normal = plane.normal;
    c.offset_m = plane.offset_m;
    // A position the law rejected gives no penetration (the law commanded zero force for it).
    c.penetration_m = position_usable ? plane.normal.dot(position_m) - plane.offset_m : 0.0;
  }
}

}  // namespace teleop::device
