#pragma once

#include <array>
#include <cstdint>

#include "device/cobot/planar.hpp"

namespace teleop::device::cobot {

/// The constraint seen from one point (the wheel contact point), as §4 of Colgate et al. describes it (Fig. 5).
struct ConstraintSample {
  Vec2 closest_m = Vec2::Zero();    ///< Nearest point of the constraint curve (m, world).
  Vec2 tangent = Vec2::UnitX();     ///< Unit tangent of the curve at closest_m (either direction along it).
  Vec2 normal_in = Vec2::UnitY();   ///< Unit normal at closest_m pointing into the forbidden side.
  double penetration_m = 0.0;       ///< p: signed distance into the forbidden side (> 0: inside the wall).
  double curvature_away_per_m = 0;  ///< 1/ρ: path curvature, > 0 when the curve bends away from the forbidden side.
};

/// A planar constraint curve with a forbidden side: a straight line, a circle, or a polyline. Fixed storage, so
/// Evaluate() is real-time safe. Build one with the factory functions; they throw teleop::Error on bad geometry.
class Constraint {
 public:
  enum class Kind : std::uint8_t { kLine, kCircle, kPolyline };
  static constexpr int kMaxPolylinePoints = 32;

  /// The line through `point_m` along `direction` (any length > 0). `forbidden_left`: the forbidden side is to the
  /// left of `direction` (counter-clockwise), else to its right.
  static Constraint Line(const Vec2& point_m, const Vec2& direction, bool forbidden_left);
  /// The half-plane boundary {p : normal·p = offset_m}, forbidden where normal·p > offset_m (a fixture plane).
  /// For use in the cycle: false (and `out` unchanged) when the normal is zero or not finite.
  [[nodiscard]] static bool TryHalfPlane(const Vec2& normal, double offset_m, Constraint& out) noexcept;
  /// The circle about `center_m` of `radius_m` > 0. `forbidden_outside`: the free region is the disc (the paper's
  /// circular constraint, tracked from inside); else the disc is an obstacle.
  static Constraint Circle(const Vec2& center_m, double radius_m, bool forbidden_outside);
  /// The same, for use in the cycle: false (and `out` unchanged) instead of an exception on bad geometry.
  [[nodiscard]] static bool TryCircle(const Vec2& center_m, double radius_m, bool forbidden_outside,
                                      Constraint& out) noexcept;
  /// An open polyline through 2..kMaxPolylinePoints distinct points; the first and last segments extend as rays.
  /// `forbidden_left`: the forbidden side is to the left when walking from the first point to the last.
  template <typename Points>
  static Constraint Polyline(const Points& points_m, bool forbidden_left) {
    Constraint c;
    c.kind_ = Kind::kPolyline;
    c.forbidden_left_ = forbidden_left;
    c.point_count_ = 0;
    for (const Vec2& p : points_m) {
      c.AppendPoint(p);
    }
    c.FinishPolyline();
    return c;
  }

  /// The constraint as seen from `point_m` (m, world).
  [[nodiscard]] ConstraintSample Evaluate(const Vec2& point_m) const noexcept;

  Kind kind() const noexcept { return kind_; }
  /// Line: a point on it; circle: the centre.
  const Vec2& anchor_m() const noexcept { return anchor_m_; }
  /// Circle radius (m); 0 for the others.
  double radius_m() const noexcept { return radius_m_; }
  int point_count() const noexcept { return point_count_; }
  const Vec2& point_m(int i) const noexcept { return points_m_[static_cast<std::size_t>(i)]; }

 private:
  void AppendPoint(const Vec2& p);
  void FinishPolyline() const;
  [[nodiscard]] ConstraintSample EvaluateLine(const Vec2& a, const Vec2& dir, const Vec2& p) const noexcept;

  Kind kind_ = Kind::kLine;
  Vec2 anchor_m_ = Vec2::Zero();
  Vec2 direction_ = Vec2::UnitX();
  double radius_m_ = 0.0;
  bool forbidden_left_ = true;     ///< Line and polyline.
  bool forbidden_outside_ = true;  ///< Circle.
  int point_count_ = 0;
  std::array<Vec2, kMaxPolylinePoints> points_m_{};
};

}  // namespace teleop::device::cobot
