// The command channel's handlers (TeleopNode::Request*): checked on the CALLER's thread, handed to the cycle
// through the command queue (command_queue.hpp), which the cycle drains once per cycle into one Changes value.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>

#include "teleop/config/render_check.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/error.hpp"
#include "teleop_node_impl.hpp"

namespace teleop::node {

namespace {

std::string Num(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

/// The largest |offset| of a plane move: the workspace's corner distance, sqrt(dof)·safety.max_abs_position_m (1000 m,
/// the key's maximum, when the check is off); any plane farther away is wholly outside a workspace.
double PlaneOffsetBound_m(const config::ProcessConfig& c) {
  const double box_m = c.safety.max_abs_position_m > 0.0 ? c.safety.max_abs_position_m : 1e3;
  return box_m * std::sqrt(static_cast<double>(c.dof));
}

}  // namespace

namespace {

/// The check's verdict on `candidate` into `change` (limit, accepted, message); `what` prefixes the message.
void Check(const config::ProcessConfig& candidate, const std::string& what, TeleopNode::FixtureChange& change) {
  try {
    const config::StabilityReport report = config::CheckProcessStability(candidate);
    if (!report.applicable()) {
      change.message = what + "the stability check does not apply: " + report.not_applicable;
      return;
    }
    change.limit_N_per_m = report.worst().limit.max_stable_stiffness_N_per_m;
    change.accepted = report.stable();
    change.message =
        what + (change.accepted ? config::DescribePass(candidate, report) : config::DescribeFailure(candidate, report));
  } catch (const Error& e) {
    change.message = what + e.what();
  }
}

const char* const kQueueFull = "; not applied: the cycle has not taken the pending commands (queue full)";

/// The stiffness the fixture may have under the watchers' bounds (TeleopNode::Impl::fixture_bounds).
double Bounded(const std::array<double, 2>& bounds, double stiffness_N_per_m) {
  double k = stiffness_N_per_m;
  for (const double bound : bounds) k = std::min(k, bound);
  return k;
}

}  // namespace

TeleopNode::FixtureChange TeleopNode::RequestFixtureStiffness(double stiffness_N_per_m, double ramp_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  change.requested_N_per_m = stiffness_N_per_m;
  if (!std::isfinite(stiffness_N_per_m) || stiffness_N_per_m < 0.0) {
    change.message = "fixture stiffness must be finite and >= 0 N/m";
  } else if (s.check_base.law.fixture.plane_count == 0 && stiffness_N_per_m > 0.0) {
    change.message = "this process has no fixture plane";
  } else {
    config::ProcessConfig candidate = s.check_base;
    candidate.law.fixture.stiffness_N_per_m = stiffness_N_per_m;
    Check(candidate, "", change);
  }
  PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kCommandAccepted : Event::Kind::kCommandRefused;
  p.value = change.accepted ? stiffness_N_per_m : change.limit_N_per_m;
  if (change.accepted) {
    p.change = PendingCommand::Change::kStiffness;
    p.stiffness_N_per_m = Bounded(s.fixture_bounds, stiffness_N_per_m);
    p.ramp_s = std::isfinite(ramp_s) && ramp_s > 0.0 ? ramp_s : 0.0;
    if (p.stiffness_N_per_m < stiffness_N_per_m) {
      change.message += "; held at " + Num(p.stiffness_N_per_m) +
                        " N/m while the run-time limit (delay re-check or configuration limit) bounds it";
    }
  }
  if (!s.commands.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law.fixture.stiffness_N_per_m = stiffness_N_per_m;  // the next check's base
    if (stiffness_N_per_m > 0.0) s.fixture_on_N_per_m = stiffness_N_per_m;
  }
  return change;
}

TeleopNode::FixtureChange TeleopNode::RequestFixtureStiffnessWithinConfigured(FixtureBound source, double bound_N_per_m,
                                                                              double ramp_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  change.requested_N_per_m = bound_N_per_m;
  if (std::isnan(bound_N_per_m) || bound_N_per_m < 0.0) {
    change.message = "a fixture bound must be >= 0 N/m (or +inf: none)";
    return change;
  }
  s.fixture_bounds[static_cast<std::size_t>(source)] = bound_N_per_m;
  const double accepted = s.check_base.law.fixture.stiffness_N_per_m;
  PendingCommand p;
  p.kind = Event::Kind::kCommandAccepted;
  p.change = PendingCommand::Change::kStiffness;
  p.stiffness_N_per_m = Bounded(s.fixture_bounds, accepted);
  p.value = p.stiffness_N_per_m;
  p.ramp_s = std::isfinite(ramp_s) && ramp_s > 0.0 ? ramp_s : 0.0;
  if (!s.commands.Post(p)) {
    change.message = std::string("fixture bound ") + Num(bound_N_per_m) + " N/m" + kQueueFull;
    return change;
  }
  change.accepted = true;
  change.message = "fixture " + Num(p.stiffness_N_per_m) + " N/m: the least of the accepted " + Num(accepted) +
                   " N/m and the run-time bounds (delay re-check " + Num(s.fixture_bounds[0]) +
                   ", configuration limit " + Num(s.fixture_bounds[1]) + ")";
  return change;
}

double TeleopNode::accepted_fixture_stiffness_N_per_m() const {
  const std::lock_guard<std::mutex> lock(impl_->command_mutex);
  return impl_->check_base.law.fixture.stiffness_N_per_m;
}

void TeleopNode::SetFixtureLimit(double limit_N_per_m) noexcept {
  impl_->fixture_limit_N_per_m.store(limit_N_per_m, std::memory_order_relaxed);
}

TeleopNode::FixtureChange TeleopNode::RequestFixtureEnabled(bool on, double ramp_s) {
  double target = 0.0;
  if (on) {
    const std::lock_guard<std::mutex> lock(impl_->command_mutex);
    target = impl_->fixture_on_N_per_m;
  }
  if (on && target <= 0.0) {
    FixtureChange change;
    change.message = "no fixture stiffness to turn on (none configured or accepted yet)";
    RecordCommandEvent(Event::Kind::kCommandRefused, 0.0);
    return change;
  }
  return RequestFixtureStiffness(target, ramp_s);
}

TeleopNode::FixtureChange TeleopNode::RequestGain(GainName name, int axis, double value, double ramp_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  const int dof = s.check_base.dof;
  const std::string what = std::string("gain ") + ToString(name) +
                           (axis < 0 ? std::string() : "[" + std::to_string(axis) + "]") + " " + Num(value) + ": ";
  config::ProcessConfig candidate = s.check_base;
  control::ThreeChannelLaw::Config& law = candidate.law;
  DofVector* gain = name == GainName::kKp   ? &law.kp_N_per_m
                    : name == GainName::kKd ? &law.kd_Ns_per_m
                    : name == GainName::kKv ? &law.kv_Ns_per_m
                                            : &law.kf;
  if (axis < -1 || axis >= dof) {
    change.message = what + "axis " + std::to_string(axis) + " is outside 0.." + std::to_string(dof - 1);
  } else if (!std::isfinite(value) || (name != GainName::kKf && value < 0.0)) {
    change.message = what + "the gain must be finite" + (name != GainName::kKf ? " and >= 0" : "");
  } else if (name == GainName::kKf && s.check_base.role == Role::kSlave && value != 0.0) {
    change.message = what + "kf is the master's force feed-forward (eq. 8); the slave law (eq. 9) has none";
  } else {
    if (axis < 0) {
      gain->setConstant(value);
    } else {
      (*gain)[axis] = value;
    }
    try {
      config::RequireRenderable(candidate, s.device->capabilities(), s.device->name());
      Check(candidate, what, change);
    } catch (const Error& e) {
      change.message = what + e.what();
    }
  }
  PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kGainAccepted : Event::Kind::kGainRefused;
  p.value = change.accepted ? value : change.limit_N_per_m;
  p.detail = GainDetail(name, axis);
  if (change.accepted) {
    p.change = PendingCommand::Change::kGains;
    p.ramp_s = std::isfinite(ramp_s) && ramp_s > 0.0 ? ramp_s : 0.0;
    const DofVector* gains[4] = {&law.kp_N_per_m, &law.kd_Ns_per_m, &law.kv_Ns_per_m, &law.kf};
    for (std::size_t g = 0; g < 4; ++g) {
      for (int i = 0; i < dof; ++i) p.gains[g][static_cast<std::size_t>(i)] = (*gains[g])[i];
    }
  }
  if (!s.commands.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law = candidate.law;
  }
  return change;
}

TeleopNode::FixtureChange TeleopNode::RequestFixturePlane(const DofVector& normal, double offset_m,
                                                          double rate_m_per_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  const control::ForbiddenRegionFixture::Config& fixture = s.check_base.law.fixture;
  const int dof = s.check_base.dof;
  const double max_rate = fixture.max_offset_rate_m_per_s;
  const double rate = rate_m_per_s > 0.0 ? rate_m_per_s : max_rate;
  DofVector n = normal;
  if (fixture.plane_count == 0) {
    change.message = "this process has no fixture plane";
  } else if (normal.size() != dof) {
    change.message = "the normal needs dof = " + std::to_string(dof) + " entries, got " + std::to_string(normal.size());
  } else if (!AllFinite(normal) || !std::isfinite(offset_m) || !std::isfinite(rate_m_per_s)) {
    change.message = "the plane's offset, normal and rate must be finite";
  } else if (std::abs(offset_m) > PlaneOffsetBound_m(s.check_base)) {
    change.message = "offset " + Num(offset_m) + " m is outside +-" + Num(PlaneOffsetBound_m(s.check_base)) +
                     " m (safety.max_abs_position_m on every axis: a plane farther away is beyond the workspace)";
  } else if (!(normal.norm() > 1e-9)) {
    change.message = "the normal must not be zero (it points into the forbidden region)";
  } else if (rate > max_rate) {
    change.message = "rate " + Num(rate) + " m/s is above fixture.max_offset_rate_m_per_s " + Num(max_rate);
  } else {
    n /= n.norm();
    const control::FixturePlane& now = fixture.planes[0];
    if (dof == 1 && n[0] * now.normal[0] < 0.0) {
      change.message =
          "a 1-DOF plane cannot turn: its normal keeps its sign (flipping the forbidden side would step the force)";
    } else {
      const double normal_rate = fixture.max_normal_rate_rad_per_s * rate / max_rate;
      const std::string what = "fixture plane 0 to offset " + Num(offset_m) + " m: slewing at <= " + Num(rate) +
                               " m/s and " + Num(normal_rate) +
                               " rad/s (force rate <= K_VF * rate = " + Num(fixture.stiffness_N_per_m * rate) +
                               " N/s on a still device)";
      bool same_axes = true;  // the check sees the fixture on the axes the normal has a component on
      for (int i = 0; i < dof; ++i) same_axes = same_axes && ((n[i] != 0.0) == (now.normal[i] != 0.0));
      if (same_axes) {
        change.accepted = true;  // the analysis does not depend on where the plane is (eq. 7)
        change.message = what;
      } else {
        config::ProcessConfig candidate = s.check_base;  // every axis the slew passes through
        candidate.law.fixture.planes[0].normal = (now.normal.cwiseAbs() + n.cwiseAbs()).normalized();
        Check(candidate, what + "; ", change);
      }
    }
  }
  PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kPlaneAccepted : Event::Kind::kPlaneRefused;
  p.value = change.accepted ? offset_m : 0.0;
  if (change.accepted) {
    p.change = PendingCommand::Change::kPlane;
    for (int i = 0; i < dof; ++i) p.normal[static_cast<std::size_t>(i)] = n[i];
    p.offset_m = offset_m;
    p.offset_rate_m_per_s = rate;
    p.normal_rate_rad_per_s = fixture.max_normal_rate_rad_per_s * rate / max_rate;
  }
  if (!s.commands.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law.fixture.planes[0].normal = n;
    s.check_base.law.fixture.planes[0].offset_m = offset_m;
  }
  return change;
}

bool TeleopNode::RequestPassivityMode(control::PassivityMode mode, Event::Kind kind, double value,
                                      std::uint16_t detail) noexcept {
  Impl& s = *impl_;
  PendingCommand p;
  p.kind = kind;
  p.value = value;
  p.detail = detail;
  p.change = PendingCommand::Change::kPassivity;
  p.passivity_mode = mode;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  return s.commands.Post(p);
}

void TeleopNode::RecordCommandEvent(Event::Kind kind, double value, std::uint16_t detail) noexcept {
  Impl& s = *impl_;
  PendingCommand p;
  p.kind = kind;
  p.value = value;
  p.detail = detail;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  (void)s.commands.Post(p);
}

std::uint64_t TeleopNode::command_events_dropped() const noexcept { return impl_->commands.dropped(); }

}  // namespace teleop::node
