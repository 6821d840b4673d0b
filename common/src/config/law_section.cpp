// The `law:` and `fixture:` sections (Abbott & Okamura eqs. 7-9).

#include <string>
#include <vector>

#include "sections.hpp"

namespace teleop::config::sections {

void ParseLaw(const Field& f, double rate_hz, control::ThreeChannelLaw::Config& law) {
  const Map map(f, {"kp_N_per_m", "kd_Ns_per_m", "kv_Ns_per_m", "kf", "peer_position_scale", "peer_force_scale",
                    "max_force_N", "velocity_filter_hz"});
  const int dof = law.dof;
  law.kp_N_per_m = ReadGain(map, "kp_N_per_m", dof, true, "N/m");
  law.kd_Ns_per_m = ReadGain(map, "kd_Ns_per_m", dof, true, "N·s/m");
  law.kv_Ns_per_m = ReadGain(map, "kv_Ns_per_m", dof, false, "N·s/m");
  law.kf = ZeroDof(dof);
  if (auto v = map.Optional("kf")) law.kf = ReadDofVector(*v, dof, Finite);
  const auto scale = [](const Field& e) {
    const double s = Finite(e);
    if (s == 0.0) e.Fail("must be non-zero (negative mirrors the axis)");
    return s;
  };
  if (auto v = map.Optional("peer_position_scale")) law.peer_position_scale = scale(*v);
  if (auto v = map.Optional("peer_force_scale")) law.peer_force_scale = Finite(*v);
  if (auto v = map.Optional("max_force_N")) law.max_force_N = NonNegative(*v, "N");
  if (auto v = map.Optional("velocity_filter_hz")) {
    law.velocity_filter_hz = InRange(*v, 0.0, rate_hz / 2.0, "Hz (0 = off; below half of rate_hz)");
    if (law.velocity_filter_hz >= rate_hz / 2.0) {
      v->Fail("must be below half of rate_hz (" + Num(rate_hz / 2.0) + " Hz, the Nyquist frequency), got " +
              Num(law.velocity_filter_hz));
    }
  }
}

void ParseFixture(const Field& f, int dof, control::ForbiddenRegionFixture::Config& fixture) {
  using control::ForbiddenRegionFixture;
  const Map map(f,
                {"stiffness_N_per_m", "planes", "half_space", "max_offset_rate_m_per_s", "max_normal_rate_rad_per_s"});
  fixture.dof = dof;
  fixture.stiffness_N_per_m = NonNegative(map.Required("stiffness_N_per_m"), "N/m");
  if (auto v = map.Optional("max_offset_rate_m_per_s")) fixture.max_offset_rate_m_per_s = Positive(*v, "m/s");
  if (auto v = map.Optional("max_normal_rate_rad_per_s")) fixture.max_normal_rate_rad_per_s = Positive(*v, "rad/s");
  const auto planes = map.Optional("planes");
  const auto half_space = map.Optional("half_space");
  if (planes && half_space) half_space->Fail("give either 'planes' or 'half_space', not both");
  if (!planes && !half_space)
    f.Fail("needs either 'planes: [{normal, offset_m}, ...]' or 'half_space: {axis, offset_m}'");
  if (half_space) {
    const Map hs(*half_space, {"axis", "offset_m", "direction"});
    const int axis = IntInRange(hs.Required("axis"), 0, dof - 1);
    const double offset_m = Finite(hs.Required("offset_m"));
    int direction = 1;
    if (auto v = hs.Optional("direction")) {
      direction = v->AsInt();
      if (direction != 1 && direction != -1) v->Fail("must be +1 (forbid x > offset) or -1 (forbid x < offset)");
    }
    control::FixturePlane plane;
    plane.normal = ZeroDof(dof);
    plane.normal[axis] = direction;
    plane.offset_m = direction * offset_m;
    fixture.plane_count = 1;
    fixture.planes[0] = plane;
    return;
  }
  const std::vector<Field> items = planes->AsList();
  if (items.empty() || static_cast<int>(items.size()) > ForbiddenRegionFixture::kMaxPlanes) {
    planes->Fail("expected 1.." + std::to_string(ForbiddenRegionFixture::kMaxPlanes) + " planes, got " +
                 std::to_string(items.size()));
  }
  fixture.plane_count = static_cast<int>(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const Map p(items[i], {"normal", "offset_m"});
    const Field normal_field = p.Required("normal");
    if (!normal_field.IsSequence()) normal_field.Fail("expected a list of " + std::to_string(dof) + " numbers");
    control::FixturePlane plane;
    plane.normal = ReadDofVector(normal_field, dof, Finite);
    if (!(plane.normal.norm() > 1e-9)) normal_field.Fail("the normal must not be zero");
    plane.offset_m = Finite(p.Required("offset_m"));
    fixture.planes[i] = plane;
  }
}

/// `device:`: the backend's name, and its own section `device.<backend>` read by the backend's registered reader.
/// Sections of other registered backends are rejected (they would be silently ignored).

}  // namespace teleop::config::sections
