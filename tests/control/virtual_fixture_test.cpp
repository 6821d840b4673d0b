#include "teleop/control/virtual_fixture.hpp"

#include <gtest/gtest.h>

#include <array>
#include <limits>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

DofVector Vec(std::initializer_list<double> values) {
  DofVector v(static_cast<int>(values.size()));
  int i = 0;
  for (double x : values) v[i++] = x;
  return v;
}

TEST(ForbiddenRegionFixture, OneDofIsExactlyEquation7) {
  const double k = 3000.0;
  const ForbiddenRegionFixture fixture(ForbiddenRegionFixture::Eq7(k));
  for (double x = -0.01; x <= 0.01; x += 0.00025) {
    const auto out = fixture.Step(Vec({x}));
    const double f_vf = x > 0.0 ? k * x : 0.0;                 // eq. 7
    EXPECT_NEAR(out.force_N[0], -f_vf, 1e-12) << "x = " << x;  // force on the device = -F_VF
    EXPECT_NEAR(out.max_penetration_m, x > 0.0 ? x : 0.0, 1e-15);
  }
  EXPECT_EQ(fixture.Step(Vec({0.0})).force_N[0], 0.0);  // on the surface: nothing
  EXPECT_NEAR(fixture.Step(Vec({0.002})).force_N[0], -6.0, 1e-12);
}

TEST(ForbiddenRegionFixture, MultiPlaneForcesAddAndOnlyPushOut) {
  ForbiddenRegionFixture::Config config;
  config.dof = 2;
  config.stiffness_N_per_m = 1000.0;
  config.plane_count = 2;
  config.planes[0] = {Vec({1.0, 0.0}), 0.01};
  config.planes[1] = {Vec({0.0, 1.0}), 0.02};
  const ForbiddenRegionFixture fixture(config);

  const auto corner = fixture.Step(Vec({0.013, 0.025}));  // inside both half-spaces
  EXPECT_NEAR(corner.force_N[0], -3.0, 1e-12);
  EXPECT_NEAR(corner.force_N[1], -5.0, 1e-12);
  EXPECT_NEAR(corner.max_penetration_m, 0.005, 1e-15);

  const auto one = fixture.Step(Vec({0.013, 0.0}));  // inside the first only
  EXPECT_NEAR(one.force_N[0], -3.0, 1e-12);
  EXPECT_EQ(one.force_N[1], 0.0);

  const auto outside = fixture.Step(Vec({0.0, -1.0}));
  EXPECT_EQ(outside.force_N.norm(), 0.0);
  EXPECT_EQ(outside.max_penetration_m, 0.0);
}

// max_penetration_m is the deepest plane's penetration, whatever the plane order: the deeper plane is given first,
// then last, and in the middle of three.
TEST(ForbiddenRegionFixture, ReportsTheDeepestPenetrationInAnyPlaneOrder) {
  const std::array<FixturePlane, 3> planes = {FixturePlane{Vec({1.0, 0.0}), 0.010},     // x0 > 0.010: 3 mm in
                                              FixturePlane{Vec({0.0, 1.0}), 0.020},     // x1 > 0.020: 5 mm in
                                              FixturePlane{Vec({-1.0, 0.0}), -0.014}};  // x0 < 0.014: 1 mm in
  const DofVector at = Vec({0.013, 0.025});
  const std::array<std::array<int, 3>, 3> orders = {{{1, 0, 2}, {0, 2, 1}, {2, 1, 0}}};
  for (const auto& order : orders) {
    ForbiddenRegionFixture::Config config;
    config.dof = 2;
    config.stiffness_N_per_m = 1000.0;
    config.plane_count = 3;
    for (int i = 0; i < 3; ++i)
      config.planes[static_cast<std::size_t>(i)] = planes[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])];
    const auto out = ForbiddenRegionFixture(config).Step(at);
    EXPECT_NEAR(out.max_penetration_m, 0.005, 1e-15) << "order " << order[0] << order[1] << order[2];
    // Forces add: -1000·(0.003 - 0.001) on x0, -1000·0.005 on x1.
    EXPECT_NEAR(out.force_N[0], -2.0, 1e-12);
    EXPECT_NEAR(out.force_N[1], -5.0, 1e-12);
  }
}

TEST(ForbiddenRegionFixture, NormalsAreNormalisedAndForceIsAlongMinusN) {
  ForbiddenRegionFixture::Config config;
  config.dof = 3;
  config.stiffness_N_per_m = 500.0;
  config.plane_count = 1;
  config.planes[0] = {Vec({3.0, 4.0, 0.0}), 0.0};  // unit normal (0.6, 0.8, 0)
  const ForbiddenRegionFixture fixture(config);
  const auto out = fixture.Step(Vec({0.01, 0.01, 0.3}));
  const double d = 0.6 * 0.01 + 0.8 * 0.01;
  EXPECT_NEAR(out.max_penetration_m, d, 1e-15);
  EXPECT_NEAR(out.force_N[0], -500.0 * d * 0.6, 1e-12);
  EXPECT_NEAR(out.force_N[1], -500.0 * d * 0.8, 1e-12);
  EXPECT_EQ(out.force_N[2], 0.0);
  EXPECT_NEAR(fixture.config().planes[0].normal.norm(), 1.0, 1e-15);
}

TEST(ForbiddenRegionFixture, HalfSpaceInTheNegativeDirection) {
  // Forbidden where x[1] < -0.02.
  const ForbiddenRegionFixture fixture(ForbiddenRegionFixture::HalfSpace(2, 1, -0.02, -1.0, 2000.0));
  EXPECT_EQ(fixture.Step(Vec({0.0, -0.019})).force_N.norm(), 0.0);
  const auto out = fixture.Step(Vec({0.0, -0.025}));
  EXPECT_NEAR(out.force_N[1], +10.0, 1e-12);  // pushes back towards +x[1]
  EXPECT_NEAR(out.max_penetration_m, 0.005, 1e-15);
}

TEST(ForbiddenRegionFixture, DisabledOrBadPositionGivesZero) {
  const ForbiddenRegionFixture disabled;
  EXPECT_EQ(disabled.Step(Vec({1.0})).force_N[0], 0.0);
  const ForbiddenRegionFixture fixture(ForbiddenRegionFixture::Eq7(1000.0));
  EXPECT_EQ(fixture.Step(Vec({std::numeric_limits<double>::quiet_NaN()})).force_N[0], 0.0);
  EXPECT_EQ(fixture.Step(Vec({0.1, 0.1})).force_N.size(), 1);
}

TEST(ForbiddenRegionFixture, RejectsBadConfig) {
  auto base = ForbiddenRegionFixture::Eq7(1000.0);
  auto c = base;
  c.stiffness_N_per_m = -1.0;
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.planes[0].normal = Vec({0.0});
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.planes[0].normal = Vec({1.0, 0.0});
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.planes[0].offset_m = std::numeric_limits<double>::infinity();
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.plane_count = ForbiddenRegionFixture::kMaxPlanes + 1;
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.plane_count = 0;  // stiffness without a plane is a mistake
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  c = base;
  c.dof = 0;
  EXPECT_THROW(ForbiddenRegionFixture{c}, Error);
  EXPECT_THROW(ForbiddenRegionFixture::HalfSpace(1, 1, 0.0, 1.0, 1.0), Error);
  EXPECT_THROW(ForbiddenRegionFixture::HalfSpace(1, 0, 0.0, 0.5, 1.0), Error);
  try {
    c = base;
    c.planes[0].normal = Vec({0.0});
    ForbiddenRegionFixture{c};
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("plane 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::control
