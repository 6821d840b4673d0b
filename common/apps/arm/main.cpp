// teleop-arm fk|jacobian|gravity|inertia|apparent-mass --urdf FILE --base LINK --tool LINK --q q1,q2,...
//   [--tool-offset x,y,z] [--direction x,y,z] [--gravity x,y,z] [--json]
// One configuration of a URDF arm through the same chain builder and model the arm backend uses
// (common/src/device/arm; docs/arms.md, "teleop-arm"). Errors name the URDF file and the link or joint.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <cmath>
#include <exception>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "arm_chain.hpp"
#include "arm_model.hpp"
#include "teleop/cli_help.hpp"
#include "teleop/error.hpp"
#include "teleop/version.hpp"

namespace {

using teleop::device::arm::ArmChainSpec;
using teleop::device::arm::ArmModel;
using teleop::device::arm::JointVector;

std::vector<double> ParseList(const std::string& text, const std::string& option) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw teleop::Error(fmt::format("{}: '{}' is not a number (give comma-separated numbers)", option, item));
    }
    if (!std::isfinite(values.back())) throw teleop::Error(fmt::format("{}: '{}' is not finite", option, item));
  }
  return values;
}

Eigen::Vector3d ParseVector3(const std::string& text, const std::string& option) {
  const std::vector<double> v = ParseList(text, option);
  if (v.size() != 3) throw teleop::Error(option + " takes 3 numbers x,y,z; got " + std::to_string(v.size()));
  return {v[0], v[1], v[2]};
}

/// A matrix as rows of numbers (text) or a JSON array of rows.
template <typename Matrix>
std::string Format(const Matrix& m, bool json) {
  std::ostringstream out;
  out << std::setprecision(12);
  if (json) out << "[";
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    if (json) out << (r ? "," : "") << (m.cols() > 1 ? "[" : "");
    for (Eigen::Index c = 0; c < m.cols(); ++c) out << (c ? (json ? "," : " ") : "") << m(r, c);
    if (json) out << (m.cols() > 1 ? "]" : "");
    if (!json) out << "\n";
  }
  if (json) out << "]";
  return out.str();
}

std::string JointNames(const ArmModel& model) {
  std::string names;
  for (const auto& j : model.arm().joints) names += (names.empty() ? "" : ", ") + j.name;
  return names;
}

int Run(int argc, char** argv) {
  CLI::App app{"teleop-arm: a URDF arm's kinematics and dynamics at one configuration (docs/arms.md)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-arm"));
  teleop::StandardHelp(app);
  std::string command, urdf, base, tool, q_text, direction_text = "0,0,1", offset_text = "0,0,0",
                                                 gravity_text = "0,0,-9.81";
  bool json = false;
  app.add_option("command", command, "fk, jacobian, gravity, inertia or apparent-mass")
      ->required()
      ->check(CLI::IsMember({"fk", "jacobian", "gravity", "inertia", "apparent-mass"}));
  app.add_option("--urdf", urdf, "The arm's URDF file")->required();
  app.add_option("--base", base, "The base link (frame B)")->required();
  app.add_option("--tool", tool, "The tool link")->required();
  app.add_option("--q", q_text, "Joint positions q1,q2,... (rad; m for prismatic joints), base to tool")->required();
  app.add_option("--tool-offset", offset_text, "Tool point in the tool link's frame x,y,z (m)");
  app.add_option("--direction", direction_text, "apparent-mass: the direction n in B (normalised)");
  app.add_option("--gravity", gravity_text, "Gravity in B (m/s^2)");
  app.add_flag("--json", json, "One JSON object instead of text");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  ArmChainSpec spec;
  spec.urdf_file = urdf;
  spec.base_link = base;
  spec.tool_link = tool;
  spec.p_LT = ParseVector3(offset_text, "--tool-offset");
  ArmModel model(teleop::device::arm::BuildArmChain(spec), ParseVector3(gravity_text, "--gravity"));
  const std::vector<double> q_values = ParseList(q_text, "--q");
  if (static_cast<int>(q_values.size()) != model.joint_count()) {
    throw teleop::Error("--q has " + std::to_string(q_values.size()) + " values, but the chain '" + base + "' to '" +
                        tool + "' in '" + urdf + "' has " + std::to_string(model.joint_count()) + " movable joints (" +
                        JointNames(model) + ")");
  }
  JointVector q(model.joint_count());
  for (int i = 0; i < model.joint_count(); ++i) q[i] = q_values[static_cast<std::size_t>(i)];
  for (int i = 0; i < model.joint_count(); ++i) {
    const auto& j = model.arm().joints[static_cast<std::size_t>(i)];
    if (j.bounded && (q[i] < j.lower || q[i] > j.upper)) {
      std::cerr << "teleop-arm: warning: joint '" << j.name << "' at " << q[i] << " is outside its limits [" << j.lower
                << ", " << j.upper << "]\n";
    }
  }
  if (!model.Update(q, JointVector(model.joint_count()))) {
    throw teleop::Error(
        "KDL could not evaluate the chain at this configuration (inertia not positive definite: "
        "a link without mass at the end of the chain?)");
  }

  std::ostringstream out;
  out << std::setprecision(12);
  if (command == "fk") {
    if (json) {
      out << R"({"p_BT_m":)" << Format(model.p_BT(), true) << R"(,"R_BT":)" << Format(model.R_BT(), true) << "}";
    } else {
      out << "p_BT (m, base frame): " << model.p_BT().transpose() << "\nR_BT:\n" << Format(model.R_BT(), false);
    }
  } else if (command == "jacobian") {
    if (json) {
      out << R"({"J_BT":)" << Format(model.J_BT(), true) << R"(,"translational_manipulability":)"
          << model.TranslationalManipulability() << "}";
    } else {
      out << "J_BT (6 x " << model.joint_count() << "; rows v_BT x,y,z (m/s), w_BT x,y,z (rad/s)):\n"
          << Format(model.J_BT(), false) << "translational manipulability: " << model.TranslationalManipulability()
          << "\n";
    }
  } else if (command == "gravity") {
    out << (json ? R"({"G_q_Nm":)" + Format(model.G_q(), true) + "}"
                 : "G(q) (N·m, the torque that holds the arm):\n" + Format(model.G_q().transpose(), false));
  } else if (command == "inertia") {
    out << (json ? R"({"M_q":)" + Format(model.M_q(), true) + "}" : "M(q) (kg·m²):\n" + Format(model.M_q(), false));
  } else {  // apparent-mass
    Eigen::Vector3d n = ParseVector3(direction_text, "--direction");
    if (!(n.norm() > 0.0)) throw teleop::Error("--direction must not be the zero vector");
    n.normalize();
    const double m_n = model.ApparentMass(n);
    if (json) {
      out << R"({"direction":)" << Format(n, true) << R"(,"apparent_mass_kg":)";
      if (std::isfinite(m_n)) {
        out << m_n;
      } else {
        out << "null";
      }
      out << "}";
    } else {
      out << "apparent mass along (" << n.transpose() << "): " << m_n << " kg"
          << (std::isfinite(m_n) ? "" : " (the arm cannot move along n here: singular)") << "\n";
    }
  }
  std::cout << out.str() << (json ? "\n" : "");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const teleop::Error& e) {
    std::cerr << "teleop-arm: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "teleop-arm: unexpected error: " << e.what() << "\n";
    return 2;
  }
}
