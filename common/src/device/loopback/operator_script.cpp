#include <cmath>
#include <numbers>
#include <string>

#include "teleop/device/loopback.hpp"
#include "validate.hpp"

namespace teleop::device {
namespace {

using loopback_detail::Fail;
using loopback_detail::RequireFinite;
using loopback_detail::RequireNonNegative;

/// Level of one segment at time t when it is active (hold levels come from the precomputed table).
double SegmentLevel(const OperatorSegment& s, double hold_level_N, double t) noexcept {
  switch (s.kind) {
    case OperatorSegment::Kind::kHold:
      return hold_level_N;
    case OperatorSegment::Kind::kStep:
      return s.to_N;
    case OperatorSegment::Kind::kRamp: {
      double fraction = (t - s.start_s) / s.duration_s;
      if (fraction < 0.0) fraction = 0.0;
      if (fraction > 1.0) fraction = 1.0;
      return s.from_N + (s.to_N - s.from_N) * fraction;
    }
    case OperatorSegment::Kind::kSine:
      return s.offset_N + s.amplitude_N * std::sin(2.0 * std::numbers::pi * s.frequency_hz * (t - s.start_s));
  }
  return 0.0;
}

bool ActiveAt(const OperatorSegment& s, double t) noexcept {
  return t >= s.start_s && (s.duration_s == 0.0 || t < s.start_s + s.duration_s);
}

/// Active just before t (left limit): started strictly before t and not ended before t.
bool ActiveJustBefore(const OperatorSegment& s, double t) noexcept {
  return s.start_s < t && (s.duration_s == 0.0 || t <= s.start_s + s.duration_s);
}

void ValidateOperator(const SimulatedOperatorConfig& human, int dof) {
  if (!human.enabled) return;
  RequireNonNegative(human.mass_kg, "human.mass_kg");
  RequireNonNegative(human.damping_Ns_per_m, "human.damping_Ns_per_m");
  RequireNonNegative(human.stiffness_N_per_m, "human.stiffness_N_per_m");
  if (human.segment_count < 0 || human.segment_count > SimulatedOperatorConfig::kMaxSegments) {
    Fail("human.segment_count " + std::to_string(human.segment_count) + " is out of range; use 0.." +
         std::to_string(SimulatedOperatorConfig::kMaxSegments));
  }
  for (int i = 0; i < human.segment_count; ++i) {
    const OperatorSegment& s = human.segments[static_cast<std::size_t>(i)];
    const std::string which = "human.segments[" + std::to_string(i) + "].";
    if (s.kind != OperatorSegment::Kind::kHold && s.kind != OperatorSegment::Kind::kStep &&
        s.kind != OperatorSegment::Kind::kRamp && s.kind != OperatorSegment::Kind::kSine) {
      Fail(which + "kind is not hold, step, ramp or sine");
    }
    RequireNonNegative(s.start_s, which + "start_s");
    RequireNonNegative(s.duration_s, which + "duration_s");
    if (s.kind == OperatorSegment::Kind::kRamp && s.duration_s <= 0.0) {
      Fail(which + "duration_s must be > 0 for a ramp (follow it with a hold to keep the end level)");
    }
    RequireFinite(s.from_N, which + "from_N");
    RequireFinite(s.to_N, which + "to_N");
    RequireFinite(s.amplitude_N, which + "amplitude_N");
    RequireFinite(s.offset_N, which + "offset_N");
    RequireNonNegative(s.frequency_hz, which + "frequency_hz");
    if (s.axis < 0 || s.axis >= dof) {
      Fail(which + "axis " + std::to_string(s.axis) + " is out of range for dof " + std::to_string(dof));
    }
  }
}

}  // namespace

OperatorScript::OperatorScript(const SimulatedOperatorConfig& config, int dof) : config_(config) {
  ValidateOperator(config, dof);
  if (!config.enabled) return;
  // Hold levels: the left limit, at the hold's start, of the segments listed before it on the same axis.
  for (int i = 0; i < config.segment_count; ++i) {
    const OperatorSegment& hold = config.segments[static_cast<std::size_t>(i)];
    if (hold.kind != OperatorSegment::Kind::kHold) continue;
    double level_N = 0.0;
    for (int j = 0; j < i; ++j) {
      const OperatorSegment& s = config.segments[static_cast<std::size_t>(j)];
      if (s.axis == hold.axis && ActiveJustBefore(s, hold.start_s)) {
        level_N += SegmentLevel(s, hold_level_N_[static_cast<std::size_t>(j)], hold.start_s);
      }
    }
    hold_level_N_[static_cast<std::size_t>(i)] = level_N;
  }
}

double OperatorScript::TargetForce(int axis, double time_s, double base_N) const noexcept {
  double force_N = base_N;
  if (!config_.enabled) return force_N;
  for (int i = 0; i < config_.segment_count; ++i) {
    const OperatorSegment& s = config_.segments[static_cast<std::size_t>(i)];
    if (s.axis == axis && ActiveAt(s, time_s)) {
      force_N += SegmentLevel(s, hold_level_N_[static_cast<std::size_t>(i)], time_s);
    }
  }
  return force_N;
}

}  // namespace teleop::device
