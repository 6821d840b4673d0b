// teleop-arm fk|jacobian|gravity|inertia|apparent-mass|limit --urdf FILE --base LINK --tool LINK --q q1,q2,...
//   [--tool-offset x,y,z] [--direction x,y,z] [--gravity x,y,z] [--json]
// teleop-arm limit --config FILE --q q1,q2,... [--direction x,y,z] [--json]
// teleop-arm check --config FILE
// teleop-arm simulate-motors --config FILE [--for S]
// One configuration of a URDF arm through the same chain builder and model the arm backend uses
// (common/src/device/arm; docs/arms.md, "teleop-arm"); `limit` the fixture's stability limit there with the
// processes' analysis, `check` the start-up check of a process config without starting it. Errors name the URDF
// file and the link or joint. `simulate-motors` runs the simulated arm of a config with `actuators: mit` and
// `mit.bus: can` as its seven motors on that bus (the teleop-canbus daemon, or vcan), so the host process of the same
// config drives them from another process (docs/mit-motors.md, "The arm on the teleop-canbus daemon"). Exit status:
// 0 done (check: the process would start), 1 bad input, 3 check: the process would refuse to start.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <exception>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "arm_chain.hpp"
#include "arm_model.hpp"
#include "arm_section.hpp"
#include "arm_sweep.hpp"
#include "simulated_mit_arm_client.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "teleop/cli_help.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/device/loopback.hpp"
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

/// The analysis' parameters of `limit` without --config: the processes' model (one sample of peer delay, the
/// shipped configs' 200 Hz velocity filter, teleop-analyze's defaults) with this side's gains for both sides.
struct LimitOptions {
  std::string side = "slave";
  double rate_hz = 1000.0;
  double kp = 0.0, kd = 0.0, kv = 0.0;
  double velocity_filter_hz = 200.0;
  int peer_delay_samples = 1;
  double peer_mass_kg = -1.0, peer_damping = -1.0;  // < 0: the paper's device of the other role
  double joint_damping = 0.0;
  int human_steps = 4;
};

/// The process config `limit` analyses: the file's (--config), else one built from the flags.
teleop::config::ProcessConfig LimitConfig(const std::string& config_path, const LimitOptions& o) {
  namespace config = teleop::config;
  if (!config_path.empty()) return config::LoadProcessConfig(config_path);
  config::ProcessConfig c;
  c.role = o.side == "master" ? teleop::Role::kMaster : teleop::Role::kSlave;
  c.dof = 3;
  // The device is this arm, given as stability.device below; the loopback plant only fills the slot.
  c.device = teleop::device::LoopbackDeviceConfig(teleop::device::LoopbackPlantConfig::PaperSlave(3));
  c.loop.rate_hz = o.rate_hz;
  c.law.dof = 3;
  c.law.kp_N_per_m = teleop::DofVector::Constant(3, o.kp);
  c.law.kd_Ns_per_m = teleop::DofVector::Constant(3, o.kd);
  c.law.kv_Ns_per_m = teleop::DofVector::Constant(3, o.kv);
  c.law.kf = teleop::DofVector::Zero(3);
  c.law.velocity_filter_hz = o.velocity_filter_hz;
  c.stability.peer_delay_samples = o.peer_delay_samples;
  c.stability.human_grid_steps = o.human_steps;
  if (o.peer_mass_kg >= 0.0) c.stability.peer.mass_kg = o.peer_mass_kg;
  if (o.peer_damping >= 0.0) c.stability.peer.damping_Ns_per_m = o.peer_damping;
  c.source_path = "(flags)";
  return c;
}

/// `check --config`: the start-up check of the processes, without starting one.
int RunCheck(const std::string& config_path) {
  namespace config = teleop::config;
  if (config_path.empty()) throw teleop::Error("check needs --config FILE (a teleop-master/teleop-slave config)");
  const config::ProcessConfig process = config::LoadProcessConfig(config_path);
  const config::StabilityReport report = config::CheckProcessStability(process);
  if (report.stable()) {
    std::cout << config_path << ": " << config::DescribePass(process, report) << "\n";
    if (report.applicable() && !report.sweep) {
      std::cout << config_path
                << ": note: no sweep over the device's configurations (not an arm, no fixture "
                   "plane, device.arm.fixture_sweep.samples 0, or stability.device gives the model)\n";
    }
    if (!process.stability.check) {
      std::cout << config_path << ": note: stability.check is false, the process will start without this check\n";
    }
    return 0;
  }
  std::cout << config_path << ": the process would refuse to start: " << config::DescribeFailure(process, report)
            << "\n";
  return 3;
}

std::atomic<bool> g_stop{false};
void OnStopSignal(int /*signal*/) { g_stop = true; }

/// `simulate-motors --config`: the config's simulated arm as its MIT motors on the config's bus, in real time, until
/// --for S has passed (0: until SIGINT/SIGTERM).
int RunSimulateMotors(const std::string& config_path, double for_s) {
  namespace config = teleop::config;
  using teleop::device::arm::ArmSection;
  if (config_path.empty())
    throw teleop::Error("simulate-motors needs --config FILE (a teleop-master/teleop-slave config)");
  const config::ProcessConfig process = config::LoadProcessConfig(config_path);
  if (process.device.backend != "arm") {
    throw teleop::Error(config_path + ": device.backend is '" + process.device.backend + "', not arm");
  }
  const auto& section = process.device.Section<ArmSection>();
  teleop::device::arm::SimulatedMitArmClient client(section);
  std::signal(SIGINT, OnStopSignal);
  std::signal(SIGTERM, OnStopSignal);
  std::cout << "teleop-arm: " << client.motor_count() << " simulated MIT motors (esc_id 0x" << std::hex
            << section.mit.joints.front().esc_id << "..0x" << section.mit.joints.back().esc_id << std::dec << ") of "
            << section.chain.urdf_file << " ready on the bus of " << config_path << std::endl;
  // The motors answer as soon as the host's commands reach them (one wake-up per host cycle, not a polling tick: six
  // processes share the machine in the daemon rig), and the arm moves at least every millisecond without them.
  constexpr std::int64_t kMaxWait_ns = 1'000'000;
  const std::int64_t start = client.now_ns();
  while (!g_stop && (for_s <= 0.0 || client.now_ns() - start < static_cast<std::int64_t>(for_s * 1e9))) {
    (void)client.WaitForFrames(client.now_ns() + kMaxWait_ns);
    client.Step(client.now_ns());
  }
  return 0;
}

int Run(int argc, char** argv) {
  CLI::App app{
      "teleop-arm: a URDF arm's kinematics and dynamics at one configuration, the fixture's stability "
      "limit there, and the start-up check of a process config (docs/arms.md)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-arm"));
  teleop::StandardHelp(app);
  std::string command, urdf, base, tool, q_text, direction_text = "0,0,1", offset_text = "0,0,0",
                                                 gravity_text = "0,0,-9.81", config_path;
  bool json = false;
  LimitOptions lo;
  double for_s = 0.0;
  app.add_option("command", command, "fk, jacobian, gravity, inertia, apparent-mass, limit, check or simulate-motors")
      ->required()
      ->check(CLI::IsMember(
          {"fk", "jacobian", "gravity", "inertia", "apparent-mass", "limit", "check", "simulate-motors"}));
  app.add_option("--urdf", urdf, "The arm's URDF file (limit with --config: the config's device.arm.urdf)");
  app.add_option("--base", base, "The base link (frame B)");
  app.add_option("--tool", tool, "The tool link");
  app.add_option("--q", q_text, "Joint positions q1,q2,... (rad; m for prismatic joints), base to tool");
  app.add_option("--tool-offset", offset_text, "Tool point in the tool link's frame x,y,z (m)");
  app.add_option("--direction", direction_text, "apparent-mass, limit: the direction n in B (normalised)");
  app.add_option("--gravity", gravity_text, "Gravity in B (m/s^2)");
  app.add_option(
      "--config", config_path,
      "check, simulate-motors: the process config; limit: take the arm and every analysis parameter (rate, gains, "
      "filter, peer, delays, operators) from this teleop-master/teleop-slave config");
  app.add_option("--side", lo.side, "limit without --config: the fixture analysed (this arm's role)")
      ->check(CLI::IsMember({"master", "slave"}));
  app.add_option("--rate", lo.rate_hz, "limit without --config: rate_hz (Hz)")->check(CLI::Range(1.0, 1e5));
  app.add_option("--kp", lo.kp, "limit without --config: law.kp_N_per_m, both sides (N/m)");
  app.add_option("--kd", lo.kd, "limit without --config: law.kd_Ns_per_m, both sides (N·s/m)");
  app.add_option("--kv", lo.kv, "limit without --config: law.kv_Ns_per_m, both sides (N·s/m)");
  app.add_option("--velocity-filter-hz", lo.velocity_filter_hz,
                 "limit without --config: law.velocity_filter_hz (the shipped configs' 200 Hz)");
  app.add_option("--peer-delay-samples", lo.peer_delay_samples, "limit without --config: stability.peer_delay_samples")
      ->check(CLI::Range(0, 1));
  app.add_option("--peer-mass", lo.peer_mass_kg,
                 "limit without --config: stability.peer.mass_kg (kg; < 0: the paper's device of the other role)");
  app.add_option("--peer-damping", lo.peer_damping,
                 "limit without --config: stability.peer.damping_Ns_per_m (N·s/m; < 0: the paper's)");
  app.add_option("--joint-damping", lo.joint_damping,
                 "limit without --config: the joints' viscous damping (N·m·s/rad; with --config: "
                 "device.arm.simulation.viscous_Nms_per_rad)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--human-steps", lo.human_steps, "limit without --config: stability.human_grid_steps")
      ->check(CLI::Range(1, 16));
  app.add_flag("--json", json, "One JSON object instead of text");
  app.add_option("--for", for_s, "simulate-motors: seconds (0: until SIGINT/SIGTERM)")->check(CLI::NonNegativeNumber);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  if (command == "check") return RunCheck(config_path);
  if (command == "simulate-motors") return RunSimulateMotors(config_path, for_s);

  teleop::config::ProcessConfig process;
  ArmChainSpec spec;
  double joint_damping = lo.joint_damping;
  Eigen::Vector3d gravity = ParseVector3(gravity_text, "--gravity");
  const bool from_config = command == "limit" && !config_path.empty();
  if (command == "limit") process = LimitConfig(config_path, lo);
  if (from_config) {
    if (process.device.backend != "arm") {
      throw teleop::Error(config_path + ": device.backend is '" + process.device.backend + "', not arm");
    }
    const auto& section = process.device.Section<teleop::device::arm::ArmSection>();
    spec = section.chain;
    joint_damping = section.simulation.viscous_Nms_per_rad;
    gravity = section.gravity_B();
  } else {
    for (const auto& [value, flag] : {std::pair{&urdf, "--urdf"}, {&base, "--base"}, {&tool, "--tool"}}) {
      if (value->empty())
        throw teleop::Error(command + " needs " + flag + (command == "limit" ? " (or --config)" : ""));
    }
    spec.urdf_file = urdf;
    spec.base_link = base;
    spec.tool_link = tool;
    spec.p_LT = ParseVector3(offset_text, "--tool-offset");
  }
  if (q_text.empty()) throw teleop::Error(command + " needs --q q1,q2,...");
  urdf = spec.urdf_file;
  base = spec.base_link;
  tool = spec.tool_link;
  ArmModel model(teleop::device::arm::BuildArmChain(spec), gravity);
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
  } else if (command == "limit") {
    Eigen::Vector3d n = ParseVector3(direction_text, "--direction");
    if (!(n.norm() > 0.0)) throw teleop::Error("--direction must not be the zero vector");
    n.normalize();
    const teleop::device::arm::NormalModel along = teleop::device::arm::ModelAlong(model, n, joint_damping);
    if (!std::isfinite(along.mass_kg)) {
      throw teleop::Error("the arm cannot move along the direction at this configuration (singular): no limit");
    }
    namespace config = teleop::config;
    process.stability.device.mass_kg = along.mass_kg;
    process.stability.device.damping_Ns_per_m = along.damping_Ns_per_m;
    int axis = 0;
    n.cwiseAbs().maxCoeff(&axis);
    const teleop::analysis::SampledTeleoperator system = config::StabilityModel(process, axis);
    const std::vector<teleop::analysis::HumanModel> humans = config::StabilityOperators(process);
    const teleop::analysis::FixtureSide side = config::FixtureSideOf(process.role);
    const teleop::analysis::StabilityLimit limit = teleop::analysis::FindMaxStableStiffness(system, side, humans);
    if (json) {
      out << R"({"q":)" << Format(q, true) << R"(,"p_BT_m":)" << Format(model.p_BT(), true) << R"(,"direction":)"
          << Format(n, true) << R"(,"apparent_mass_kg":)" << along.mass_kg << R"(,"damping_Ns_per_m":)"
          << along.damping_Ns_per_m << R"(,"side":")" << teleop::analysis::ToString(side) << R"(","rate_hz":)"
          << system.rate_hz << R"(,"max_stable_stiffness_N_per_m":)" << limit.max_stable_stiffness_N_per_m
          << R"(,"unstable_without_fixture":)" << (limit.unstable_without_fixture ? "true" : "false")
          << R"(,"operators":)" << humans.size() << "}";
    } else {
      out << "at q = (" << q.transpose() << "), tool at (" << model.p_BT().transpose() << ") m, along ("
          << n.transpose() << "): apparent mass " << along.mass_kg << " kg, damping " << along.damping_Ns_per_m
          << " N·s/m\npredicted limit of the " << teleop::analysis::ToString(side)
          << " fixture: " << limit.max_stable_stiffness_N_per_m << " N/m"
          << (limit.unstable_without_fixture ? " (UNSTABLE even without a fixture)" : "") << " over " << humans.size()
          << " operators\nthe same with teleop-analyze: " << config::AnalyzeCommandLine(process, axis) << "\n";
    }
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
