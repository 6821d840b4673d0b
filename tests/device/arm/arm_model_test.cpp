// The arm's chain and model (common/src/device/arm/arm_chain.hpp, arm_model.hpp): the planar 2-link arm against its
// textbook closed forms, every shipped URDF's Jacobian against finite differences of its forward kinematics, no
// allocation in Update, and each bad URDF a clear error naming the file and the link or joint.

#include "arm_model.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "arm_chain.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::device::arm {
namespace {

const std::string kRobots = TELEOP_ROBOTS_DIR;
const Eigen::Vector3d kGravity(0.0, 0.0, -9.81);

ArmChain Load(const std::string& file, const std::string& base, const std::string& tool) {
  ArmChainSpec spec;
  spec.urdf_file = kRobots + "/" + file;
  spec.base_link = base;
  spec.tool_link = tool;
  return BuildArmChain(spec);
}

JointVector RandomWithinLimits(const ArmChain& arm, std::mt19937& rng, double margin) {
  JointVector q(arm.joint_count());
  for (int i = 0; i < arm.joint_count(); ++i) {
    const JointSpec& j = arm.joints[static_cast<std::size_t>(i)];
    std::uniform_real_distribution<double> d(j.lower + margin, j.upper - margin);
    q[i] = d(rng);
  }
  return q;
}

// Planar 2-link arm: deploy/robots/planar_2link.urdf's numbers.
constexpr double kL1 = 0.5, kL2 = 0.4, kLc1 = 0.25, kLc2 = 0.2, kM1 = 2.0, kM2 = 1.5, kI1 = 0.04, kI2 = 0.02, kG = 9.81;

TEST(ArmModel, PlanarTwoLinkMatchesTheClosedForms) {
  ArmModel model(Load("planar_2link.urdf", "base", "tool"), kGravity);
  ASSERT_EQ(model.joint_count(), 2);
  std::mt19937 rng(28);
  std::uniform_real_distribution<double> angle(-3.0, 3.0), rate(-2.0, 2.0);
  for (int trial = 0; trial < 50; ++trial) {
    JointVector q(2), v(2);
    q << angle(rng), angle(rng);
    v << rate(rng), rate(rng);
    ASSERT_TRUE(model.Update(q, v));
    const double c1 = std::cos(q[0]), s1 = std::sin(q[0]), c2 = std::cos(q[1]), s2 = std::sin(q[1]);
    const double c12 = std::cos(q[0] + q[1]), s12 = std::sin(q[0] + q[1]);
    // FK in the x-z plane.
    EXPECT_NEAR(model.p_BT().x(), kL1 * c1 + kL2 * c12, 1e-9);
    EXPECT_NEAR(model.p_BT().y(), 0.0, 1e-9);
    EXPECT_NEAR(model.p_BT().z(), kL1 * s1 + kL2 * s12, 1e-9);
    // Jacobian: linear rows x and z, angular row y (turning about -y).
    const ToolJacobian& J = model.J_BT();
    EXPECT_NEAR(J(0, 0), -kL1 * s1 - kL2 * s12, 1e-9);
    EXPECT_NEAR(J(0, 1), -kL2 * s12, 1e-9);
    EXPECT_NEAR(J(2, 0), kL1 * c1 + kL2 * c12, 1e-9);
    EXPECT_NEAR(J(2, 1), kL2 * c12, 1e-9);
    EXPECT_NEAR(J(4, 0), -1.0, 1e-9);
    EXPECT_NEAR(J(4, 1), -1.0, 1e-9);
    EXPECT_NEAR(J.row(1).norm() + J.row(3).norm() + J.row(5).norm(), 0.0, 1e-9);
    // Inertia.
    const double m22 = kM2 * kLc2 * kLc2 + kI2;
    const double m12 = kM2 * (kLc2 * kLc2 + kL1 * kLc2 * c2) + kI2;
    const double m11 = kM1 * kLc1 * kLc1 + kI1 + kM2 * (kL1 * kL1 + kLc2 * kLc2 + 2.0 * kL1 * kLc2 * c2) + kI2;
    EXPECT_NEAR(model.M_q()(0, 0), m11, 1e-9);
    EXPECT_NEAR(model.M_q()(0, 1), m12, 1e-9);
    EXPECT_NEAR(model.M_q()(1, 0), m12, 1e-9);
    EXPECT_NEAR(model.M_q()(1, 1), m22, 1e-9);
    // Gravity.
    EXPECT_NEAR(model.G_q()[0], (kM1 * kLc1 + kM2 * kL1) * kG * c1 + kM2 * kLc2 * kG * c12, 1e-9);
    EXPECT_NEAR(model.G_q()[1], kM2 * kLc2 * kG * c12, 1e-9);
    // Coriolis and centrifugal torques, h = m2·l1·lc2·sin q2.
    const double h = kM2 * kL1 * kLc2 * s2;
    EXPECT_NEAR(model.C_qv()[0], -h * (2.0 * v[0] * v[1] + v[1] * v[1]), 1e-9);
    EXPECT_NEAR(model.C_qv()[1], h * v[0] * v[0], 1e-9);
    // Velocity and apparent mass along x: 1 / (eₓᵀ J M⁻¹ Jᵀ eₓ) from the closed forms.
    Eigen::Matrix2d M, Jxz;
    M << m11, m12, m12, m22;
    Jxz << J(0, 0), J(0, 1), J(2, 0), J(2, 1);
    const Eigen::Vector2d jx = Jxz.row(0).transpose();
    EXPECT_NEAR(model.ApparentMass(Eigen::Vector3d::UnitX()), 1.0 / jx.dot(M.inverse() * jx), 1e-9);
    EXPECT_NEAR(model.v_BT().x(), jx.dot(v), 1e-9);
  }
}

Eigen::Vector3d AngleOf(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// Every column of every shipped arm's J_BT against central differences of FK (h = 1e-6 rad: the error is O(h²) plus
// rounding, well below 1e-6).
void CheckJacobianByFiniteDifferences(const std::string& file, const std::string& base, const std::string& tool) {
  ArmModel model(Load(file, base, tool), kGravity);
  const int n = model.joint_count();
  std::mt19937 rng(7);
  const double h = 1e-6;
  for (int trial = 0; trial < 20; ++trial) {
    const JointVector q = RandomWithinLimits(model.arm(), rng, 0.01);
    const JointVector zero(n);
    ASSERT_TRUE(model.Update(q, zero));
    const ToolJacobian J = model.J_BT();
    for (int i = 0; i < n; ++i) {
      JointVector qp = q, qm = q;
      qp[i] += h;
      qm[i] -= h;
      ASSERT_TRUE(model.Update(qp, zero));
      const Eigen::Vector3d pp = model.p_BT();
      const Eigen::Matrix3d Rp = model.R_BT();
      ASSERT_TRUE(model.Update(qm, zero));
      const Eigen::Vector3d pm = model.p_BT();
      const Eigen::Matrix3d Rm = model.R_BT();
      const Eigen::Vector3d dp = (pp - pm) / (2.0 * h);
      const Eigen::Vector3d dw = AngleOf(Rp * Rm.transpose()) / (2.0 * h);
      EXPECT_LT((dp - J.block<3, 1>(0, i)).norm(), 1e-6) << file << " joint " << i;
      EXPECT_LT((dw - J.block<3, 1>(3, i)).norm(), 1e-6) << file << " joint " << i;
    }
  }
}

TEST(ArmModel, EveryShippedJacobianMatchesFiniteDifferences) {
  CheckJacobianByFiniteDifferences("planar_2link.urdf", "base", "tool");
  CheckJacobianByFiniteDifferences("stylus_3dof.urdf", "base", "stylus_tip");
  CheckJacobianByFiniteDifferences("arm_7dof.urdf", "base", "tool");
}

TEST(ArmModel, SevenJointInertiaIsSymmetricPositiveDefinite) {
  ArmModel model(Load("arm_7dof.urdf", "base", "tool"), kGravity);
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const JointVector q = RandomWithinLimits(model.arm(), rng, 0.01);
    ASSERT_TRUE(model.Update(q, JointVector(7)));
    const JointMatrix& M = model.M_q();
    EXPECT_LT((M - M.transpose()).norm(), 1e-12);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(M);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  }
}

TEST(ArmModel, UpdateAndQueriesDoNotAllocate) {
  ArmModel model(Load("arm_7dof.urdf", "base", "tool"), kGravity);
  std::mt19937 rng(3);
  const JointVector q = RandomWithinLimits(model.arm(), rng, 0.1);
  const JointVector v = RandomWithinLimits(model.arm(), rng, 0.1);
  ASSERT_TRUE(model.Update(q, v));  // a first call outside the counter (KDL's lazy state, if any)
  test::AllocationCounter counter;
  bool ok = true;
  double sum = 0.0;
  for (int i = 0; i < 10; ++i) {
    ok = ok && model.Update(q, v);
    sum += model.ApparentMass(Eigen::Vector3d::UnitZ()) + model.TranslationalManipulability();
    sum += model.SolveInertia(model.G_q()).sum();
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_TRUE(ok);
  EXPECT_TRUE(std::isfinite(sum));
}

TEST(ArmModel, LimitsComeFromTheUrdfAndTheConfigOverridesThem) {
  ArmChainSpec spec;
  spec.urdf_file = kRobots + "/arm_7dof.urdf";
  spec.base_link = "base";
  spec.tool_link = "tool";
  ArmChain arm = BuildArmChain(spec);
  ASSERT_EQ(arm.joint_count(), 7);
  EXPECT_EQ(arm.joints[3].name, "joint4");
  EXPECT_DOUBLE_EQ(arm.joints[3].lower, -2.09);
  EXPECT_DOUBLE_EQ(arm.joints[3].max_effort, 110.0);
  spec.limit_overrides.push_back({"joint4", -1.5, std::nullopt, std::nullopt, 50.0});
  arm = BuildArmChain(spec);
  EXPECT_DOUBLE_EQ(arm.joints[3].lower, -1.5);
  EXPECT_DOUBLE_EQ(arm.joints[3].upper, 2.09);
  EXPECT_DOUBLE_EQ(arm.joints[3].max_effort, 50.0);
  // The tool offset moves the tool point along the tool link's z (pointing up at q = 0).
  spec.p_LT = Eigen::Vector3d(0.0, 0.0, 0.1);
  ArmModel offset(BuildArmChain(spec), kGravity);
  ArmModel plain(Load("arm_7dof.urdf", "base", "tool"), kGravity);
  ASSERT_TRUE(offset.Update(JointVector(7), JointVector(7)));
  ASSERT_TRUE(plain.Update(JointVector(7), JointVector(7)));
  EXPECT_NEAR(offset.p_BT().z() - plain.p_BT().z(), 0.1, 1e-12);
}

// ---- bad URDFs and specs: each a teleop::Error naming the file and what is wrong ----------------------------------

std::string ErrorOf(const ArmChainSpec& spec) {
  try {
    (void)BuildArmChain(spec);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

class BadUrdf : public ::testing::Test {
 protected:
  ArmChainSpec Write(const std::string& body, const std::string& base = "base", const std::string& tool = "tip") {
    ArmChainSpec spec;
    spec.urdf_file = dir_.File("robot.urdf");
    std::ofstream(spec.urdf_file) << "<?xml version=\"1.0\"?>\n<robot name=\"r\">\n" << body << "</robot>\n";
    spec.base_link = base;
    spec.tool_link = tool;
    return spec;
  }
  test::ScopedTempDir dir_{"arm-urdf"};
};

const char* kOneJoint = R"(<link name="base"/><link name="tip"/><link name="side"/>
<joint name="j1" type="%TYPE%"><parent link="base"/><child link="tip"/><axis xyz="0 0 1"/>%LIMIT%</joint>
<joint name="j2" type="fixed"><parent link="base"/><child link="side"/></joint>
)";

std::string OneJoint(const std::string& type, const std::string& limit) {
  std::string s = kOneJoint;
  s.replace(s.find("%TYPE%"), 6, type);
  s.replace(s.find("%LIMIT%"), 7, limit);
  return s;
}

TEST_F(BadUrdf, MissingFileNamesIt) {
  ArmChainSpec spec;
  spec.urdf_file = dir_.File("absent.urdf");
  spec.base_link = "base";
  spec.tool_link = "tip";
  EXPECT_NE(ErrorOf(spec).find("cannot read the URDF file '" + spec.urdf_file + "'"), std::string::npos);
}

TEST_F(BadUrdf, UnparsableFileNamesIt) {
  const ArmChainSpec spec = Write("<link name=\"base\"><oops></robot");
  const std::string e = ErrorOf(spec);
  EXPECT_NE(e.find(spec.urdf_file), std::string::npos) << e;
  EXPECT_NE(e.find("not a valid URDF"), std::string::npos) << e;
}

TEST_F(BadUrdf, MissingLinksAreNamed) {
  const std::string limit = R"(<limit lower="-1" upper="1" effort="5" velocity="1"/>)";
  EXPECT_NE(ErrorOf(Write(OneJoint("revolute", limit), "base", "hand")).find("no link named 'hand' (the tool link)"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Write(OneJoint("revolute", limit), "floor", "tip")).find("no link named 'floor' (the base link)"),
            std::string::npos);
}

TEST_F(BadUrdf, ToolNotDownstreamOfBase) {
  const std::string limit = R"(<limit lower="-1" upper="1" effort="5" velocity="1"/>)";
  const std::string e = ErrorOf(Write(OneJoint("revolute", limit), "side", "tip"));
  EXPECT_NE(e.find("the tool link 'tip' is not downstream of the base link 'side'"), std::string::npos) << e;
}

TEST_F(BadUrdf, JointTypeKdlCannotTake) {
  const std::string e = ErrorOf(Write(OneJoint("floating", "")));
  EXPECT_NE(e.find("joint 'j1' is floating"), std::string::npos) << e;
}

TEST_F(BadUrdf, MissingJointLimits) {
  // A continuous joint without <limit> has no effort limit; a revolute one with lower = upper has no range.
  std::string e = ErrorOf(Write(OneJoint("continuous", "")));
  EXPECT_NE(e.find("joint 'j1' has no effort limit"), std::string::npos) << e;
  e = ErrorOf(Write(OneJoint("revolute", R"(<limit effort="5" velocity="1"/>)")));
  EXPECT_NE(e.find("joint 'j1' has no position range"), std::string::npos) << e;
  // The config's override supplies what the URDF lacks.
  ArmChainSpec spec = Write(OneJoint("continuous", ""));
  spec.limit_overrides.push_back({"j1", std::nullopt, std::nullopt, std::nullopt, 2.0});
  EXPECT_EQ(BuildArmChain(spec).joints[0].max_effort, 2.0);
  spec.limit_overrides[0].joint = "j9";
  e = ErrorOf(spec);
  EXPECT_NE(e.find("joint_limits names joint 'j9'"), std::string::npos) << e;
}

}  // namespace
}  // namespace teleop::device::arm
