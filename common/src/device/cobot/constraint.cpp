#include "device/cobot/constraint.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

namespace {
constexpr double kMinLength_m = 1e-9;

/// A circle of `radius_m` around `center_m`; the forbidden side outside (forbidden_outside) or inside.
ConstraintSample EvaluateCircle(const Vec2& center_m, double radius_m, bool forbidden_outside,
                                const Vec2& point_m) noexcept {
  const Vec2 r = point_m - center_m;
  const double dist = r.norm();
  const Vec2 radial = dist > kMinLength_m ? Vec2(r / dist) : Vec2::UnitX();
  ConstraintSample s;
  s.closest_m = center_m + radius_m * radial;
  s.tangent = LeftNormal(radial);
  if (forbidden_outside) {
    s.normal_in = radial;
    s.penetration_m = dist - radius_m;
    s.curvature_away_per_m = 1.0 / radius_m;
  } else {
    s.normal_in = -radial;
    s.penetration_m = radius_m - dist;
    s.curvature_away_per_m = -1.0 / radius_m;
  }
  return s;
}

/// A polyline's interior `vertex` as the nearest feature (between the points `before` and `after`): the side from
/// the mean of the adjacent segments' inward normals.
ConstraintSample EvaluateVertex(const Vec2& before, const Vec2& vertex, const Vec2& after, bool forbidden_left,
                                const Vec2& point_m) noexcept {
  const Vec2 d = point_m - vertex;
  const double dist = d.norm();
  const Vec2 d_prev = (vertex - before).normalized();
  const Vec2 d_next = (after - vertex).normalized();
  const double side = forbidden_left ? 1.0 : -1.0;
  const Vec2 pseudo_normal = side * (LeftNormal(d_prev) + LeftNormal(d_next));
  ConstraintSample s;
  s.closest_m = vertex;
  if (dist > kMinLength_m) {
    const bool inside = d.dot(pseudo_normal) > 0.0;
    s.normal_in = inside ? Vec2(d / dist) : Vec2(-d / dist);
    s.penetration_m = inside ? dist : -dist;
  } else {
    s.normal_in =
        pseudo_normal.norm() > kMinLength_m ? Vec2(pseudo_normal.normalized()) : Vec2(side * LeftNormal(d_prev));
    s.penetration_m = 0.0;
  }
  // Tangent: the normal turned back so that the walking direction keeps the forbidden side where it was.
  s.tangent = side > 0.0 ? Vec2(-LeftNormal(s.normal_in)) : LeftNormal(s.normal_in);
  s.curvature_away_per_m = 0.0;
  return s;
}

}  // namespace

Constraint Constraint::Line(const Vec2& point_m, const Vec2& direction, bool forbidden_left) {
  if (!point_m.allFinite() || !direction.allFinite() || direction.norm() < kMinLength_m) {
    throw Error("cobot constraint: a line needs a finite point and a non-zero finite direction");
  }
  Constraint c;
  c.kind_ = Kind::kLine;
  c.anchor_m_ = point_m;
  c.direction_ = direction.normalized();
  c.forbidden_left_ = forbidden_left;
  return c;
}

Constraint Constraint::Circle(const Vec2& center_m, double radius_m, bool forbidden_outside) {
  if (!center_m.allFinite() || !std::isfinite(radius_m) || radius_m <= kMinLength_m) {
    throw Error("cobot constraint: a circle needs a finite centre and a radius > 0 m (got " + std::to_string(radius_m) +
                ")");
  }
  Constraint c;
  c.kind_ = Kind::kCircle;
  c.anchor_m_ = center_m;
  c.radius_m_ = radius_m;
  c.forbidden_outside_ = forbidden_outside;
  return c;
}

bool Constraint::TryHalfPlane(const Vec2& normal, double offset_m, Constraint& out) noexcept {
  const double length = normal.norm();
  if (!normal.allFinite() || !std::isfinite(offset_m) || length < kMinLength_m) {
    return false;
  }
  const Vec2 n = normal / length;
  out.kind_ = Kind::kLine;
  out.anchor_m_ = n * (offset_m / length);
  out.direction_ = -LeftNormal(n);  // so that the left of the direction is n: the forbidden side
  out.forbidden_left_ = true;
  out.point_count_ = 0;
  return true;
}

bool Constraint::TryCircle(const Vec2& center_m, double radius_m, bool forbidden_outside, Constraint& out) noexcept {
  if (!center_m.allFinite() || !std::isfinite(radius_m) || radius_m <= kMinLength_m) {
    return false;
  }
  out.kind_ = Kind::kCircle;
  out.anchor_m_ = center_m;
  out.radius_m_ = radius_m;
  out.forbidden_outside_ = forbidden_outside;
  out.point_count_ = 0;
  return true;
}

void Constraint::AppendPoint(const Vec2& p) {
  if (point_count_ >= kMaxPolylinePoints) {
    throw Error("cobot constraint: a polyline has at most " + std::to_string(kMaxPolylinePoints) + " points");
  }
  if (!p.allFinite()) {
    throw Error("cobot constraint: polyline point " + std::to_string(point_count_) + " is not finite");
  }
  if (point_count_ > 0 && (p - points_m_[static_cast<std::size_t>(point_count_) - 1]).norm() < kMinLength_m) {
    throw Error("cobot constraint: polyline points " + std::to_string(point_count_ - 1) + " and " +
                std::to_string(point_count_) + " coincide");
  }
  points_m_[static_cast<std::size_t>(point_count_)] = p;
  ++point_count_;
}

void Constraint::FinishPolyline() const {
  if (point_count_ < 2) {
    throw Error("cobot constraint: a polyline needs at least 2 points");
  }
}

ConstraintSample Constraint::EvaluateLine(const Vec2& a, const Vec2& dir, const Vec2& p) const noexcept {
  ConstraintSample s;
  s.tangent = dir;
  s.normal_in = forbidden_left_ ? LeftNormal(dir) : Vec2(-LeftNormal(dir));
  s.penetration_m = (p - a).dot(s.normal_in);
  s.closest_m = p - s.penetration_m * s.normal_in;
  s.curvature_away_per_m = 0.0;
  return s;
}

ConstraintSample Constraint::Evaluate(const Vec2& point_m) const noexcept {
  switch (kind_) {
    case Kind::kLine:
      return EvaluateLine(anchor_m_, direction_, point_m);
    case Kind::kCircle:
      return EvaluateCircle(anchor_m_, radius_m_, forbidden_outside_, point_m);
    case Kind::kPolyline:
      break;
  }
  // Polyline: the nearest feature (segment interior or vertex); the end segments extend as rays.
  double best = std::numeric_limits<double>::infinity();
  ConstraintSample best_sample;
  const int last = point_count_ - 1;
  for (int i = 0; i < last; ++i) {
    const Vec2& a = points_m_[static_cast<std::size_t>(i)];
    const Vec2& b = points_m_[static_cast<std::size_t>(i) + 1];
    const Vec2 seg = b - a;
    const double len = seg.norm();
    const Vec2 dir = seg / len;
    const double t = (point_m - a).dot(dir);
    const bool clamp_low = i > 0 && t < 0.0;
    const bool clamp_high = i < last - 1 && t > len;
    if (!clamp_low && !clamp_high) {
      const ConstraintSample s = EvaluateLine(a, dir, point_m);
      if (std::abs(s.penetration_m) < best) {
        best = std::abs(s.penetration_m);
        best_sample = s;
      }
      continue;
    }
    // Nearest to an interior vertex.
    const auto v = static_cast<std::size_t>(clamp_low ? i : i + 1);
    const double dist = (point_m - points_m_[v]).norm();
    if (dist >= best) {
      continue;
    }
    best = dist;
    best_sample = EvaluateVertex(points_m_[v - 1], points_m_[v], points_m_[v + 1], forbidden_left_, point_m);
  }
  return best_sample;
}

}  // namespace teleop::device::cobot
