// The simulated arm (simulated_arm.hpp).

#include "simulated_arm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device::arm {

class SimulatedArm::Joint final : public JointActuator {
 public:
  Joint(SimulatedArm& arm, int index) : arm_(arm), index_(index) {}
  void Read(JointSample& out) noexcept override {
    const double q = arm_.q_[index_];
    const double step = arm_.config_.encoder_resolution_rad;
    out.position = step > 0.0 ? step * std::round(q / step) : q;
    if (non_finite_) out.position = std::numeric_limits<double>::quiet_NaN();
    out.velocity = arm_.v_[index_];
    out.torque_Nm = arm_.tau_[index_];
    out.fault = fault_code_ != 0;
    out.fault_code = fault_code_;
  }
  void WriteTorque(double torque_Nm) noexcept override {
    const double limit = arm_.max_effort_[index_];
    arm_.tau_[index_] = std::isfinite(torque_Nm) && fault_code_ == 0 ? std::clamp(torque_Nm, -limit, limit) : 0.0;
  }
  std::uint32_t fault_code_ = 0;
  bool non_finite_ = false;

 private:
  SimulatedArm& arm_;
  int index_;
};

SimulatedArm::SimulatedArm(ArmChain arm, const Eigen::Vector3d& gravity_B, SimulatedArmConfig config)
    : model_(std::move(arm), gravity_B), config_(std::move(config)), n_(model_.joint_count()), llt_(n_) {
  if (config_.substeps < 1) throw Error("arm simulation: substeps must be >= 1");
  q_ = JointVector(n_);
  v_ = JointVector(n_);
  tau_ = JointVector(n_);
  max_effort_ = JointVector(n_);
  lower_ = JointVector(n_);
  upper_ = JointVector(n_);
  for (int i = 0; i < n_; ++i) {
    const JointSpec& j = model_.arm().joints[static_cast<std::size_t>(i)];
    max_effort_[i] = j.max_effort;
    lower_[i] = j.bounded ? j.lower : -std::numeric_limits<double>::infinity();
    upper_[i] = j.bounded ? j.upper : std::numeric_limits<double>::infinity();
    q_[i] = j.bounded ? 0.5 * (j.lower + j.upper) : 0.0;
  }
  if (config_.initial_q.size() != 0) {
    if (config_.initial_q.size() != n_) {
      throw Error("arm simulation: initial_q_rad has " + std::to_string(config_.initial_q.size()) +
                  " values; the arm has " + std::to_string(n_) + " joints");
    }
    q_ = config_.initial_q;
  }
  for (int i = 0; i < n_; ++i) joints_.push_back(std::make_unique<Joint>(*this, i));
  M_eff_ = JointMatrix::Identity(n_, n_);
  if (!model_.Update(q_, v_)) throw Error("arm simulation: the model cannot be evaluated at the initial q");
  hand_rest_ = model_.p_BT();
}

SimulatedArm::~SimulatedArm() = default;

JointActuator& SimulatedArm::joint(int i) noexcept { return *joints_[static_cast<std::size_t>(i)]; }

void SimulatedArm::InjectFault(int i, std::uint32_t code) noexcept {
  joints_[static_cast<std::size_t>(i)]->fault_code_ = code;
}
void SimulatedArm::InjectNonFinite(int i) noexcept { joints_[static_cast<std::size_t>(i)]->non_finite_ = true; }

void SimulatedArm::Exchange(double period_s) noexcept {
  const double h = period_s / config_.substeps;
  for (int s = 0; s < config_.substeps; ++s) Substep(h);
}

void SimulatedArm::Substep(double h) noexcept {
  if (!model_.Update(q_, v_)) return;
  const auto Jv = model_.J_BT().topRows<3>();
  const Eigen::Vector3d p = model_.p_BT();
  const Eigen::Vector3d pdot = model_.v_BT();
  Eigen::Vector3d f_ext = Eigen::Vector3d::Zero();
  M_eff_ = model_.M_q();
  if (config_.hand_mass_kg > 0.0 || config_.hand_stiffness_N_per_m > 0.0) {
    M_eff_.noalias() += config_.hand_mass_kg * Jv.transpose() * Jv;
    f_ext += -config_.hand_stiffness_N_per_m * (p - hand_rest_) - config_.hand_damping_Ns_per_m * pdot;
    if (time_s_ >= config_.hand_push_start_s) f_ext += config_.hand_push_N;
  }
  env_force_N_.setZero();
  penetration_m_ = 0.0;
  if (config_.environment) {
    const Eigen::Vector3d& n = config_.environment_normal;
    penetration_m_ = n.dot(p) - config_.environment_offset_m;
    if (penetration_m_ > 0.0) {
      const double push = std::max(0.0, config_.environment_stiffness_N_per_m * penetration_m_ +
                                            config_.environment_damping_Ns_per_m * n.dot(pdot));
      env_force_N_ = -push * n;
      f_ext += env_force_N_;
    }
  }
  JointVector rhs(tau_ - model_.C_qv() - model_.G_q() + Jv.transpose() * f_ext);
  for (int i = 0; i < n_; ++i) {
    rhs[i] -= config_.viscous_Nms_per_rad * v_[i] + config_.coulomb_Nm * std::tanh(v_[i] / 0.01);
    if (q_[i] > upper_[i]) {
      rhs[i] -= config_.stop_stiffness_Nm_per_rad * (q_[i] - upper_[i]) + config_.stop_damping_Nms_per_rad * v_[i];
    } else if (q_[i] < lower_[i]) {
      rhs[i] += config_.stop_stiffness_Nm_per_rad * (lower_[i] - q_[i]) - config_.stop_damping_Nms_per_rad * v_[i];
    }
  }
  llt_.compute(M_eff_);
  const JointVector qdd(llt_.solve(rhs));
  v_ += h * qdd;
  q_ += h * v_;
  time_s_ += h;
}

}  // namespace teleop::device::arm
