#include "test_utilities/closed_loop.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::test {
namespace {

using control::ThreeChannelLaw;

ThreeChannelLaw::Config OneDofLaw(Role role, double kp, double kd, double kv, double kf, double fixture_N_per_m,
                                  const OneDofSetup& setup) {
  ThreeChannelLaw::Config law = ThreeChannelLaw::ZeroGains(role, 1);
  law.kp_N_per_m[0] = kp;
  law.kd_Ns_per_m[0] = kd;
  law.kv_Ns_per_m[0] = kv;
  law.kf[0] = kf;
  law.velocity_filter_hz = setup.velocity_filter_hz;
  law.max_force_N = setup.max_force_N;
  if (fixture_N_per_m != 0.0) law.fixture = control::ForbiddenRegionFixture::Eq7(fixture_N_per_m);
  return law;
}

int CyclesFor(double duration_s, double rate_hz) {
  if (!std::isfinite(duration_s) || duration_s < 0.0) throw Error("closed loop: duration_s must be finite and >= 0");
  return static_cast<int>(std::lround(duration_s * rate_hz));
}

}  // namespace

ClosedLoopConfig MakeOneDofConfig(const OneDofSetup& setup) {
  ClosedLoopConfig config;
  config.rate_hz = setup.rate_hz;
  config.delay_cycles = setup.delay_cycles;
  config.jitter_cycles = setup.jitter_cycles;
  config.loss = setup.loss;
  config.seed = setup.seed;
  config.master_law = OneDofLaw(Role::kMaster, setup.kpm_N_per_m, setup.kdm_Ns_per_m, setup.kvm_Ns_per_m, setup.kfm,
                                setup.master_fixture_N_per_m, setup);
  config.slave_law = OneDofLaw(Role::kSlave, setup.kps_N_per_m, setup.kds_Ns_per_m, setup.kvs_Ns_per_m, 0.0,
                               setup.slave_fixture_N_per_m, setup);
  config.master_plant.mass_kg = setup.master_mass_kg;
  config.master_plant.damping_Ns_per_m = setup.master_damping_Ns_per_m;
  config.master_plant.encoder_resolution_m = setup.encoder_resolution_m;
  config.slave_plant.mass_kg = setup.slave_mass_kg;
  config.slave_plant.damping_Ns_per_m = setup.slave_damping_Ns_per_m;
  config.slave_plant.encoder_resolution_m = setup.encoder_resolution_m;

  device::SimulatedOperatorConfig& human = config.master_plant.human;
  human.enabled = true;
  human.mass_kg = setup.human_mass_kg;
  human.damping_Ns_per_m = setup.human_damping_Ns_per_m;
  human.stiffness_N_per_m = setup.human_stiffness_N_per_m;
  using Kind = device::OperatorSegment::Kind;
  if (setup.operator_ramp_s > 0.0) {
    human.segment_count = 2;
    human.segments[0] = {Kind::kRamp, 0.0, setup.operator_ramp_s, 0.0, setup.operator_force_N, 0.0, 0.0, 0.0, 0};
    human.segments[1] = {Kind::kHold, setup.operator_ramp_s, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0};
  } else {
    human.segment_count = 1;
    human.segments[0] = {Kind::kStep, 0.0, 0.0, 0.0, setup.operator_force_N, 0.0, 0.0, 0.0, 0};
  }
  return config;
}

control::PassivityController::Config ClosedLoopConfig::PassivityOff(int dof) {
  control::PassivityController::Config config;
  config.dof = dof;
  config.max_damping_Ns_per_m = ZeroDof(dof);
  return config;
}

void ClosedLoop::DelayLine::Push(const WireSample& sample, std::uint64_t cycle, const ClosedLoopConfig& config) {
  Slot& slot = ring[pushed % ring.size()];
  slot.sample = sample;
  slot.index = pushed;
  slot.sent_cycle = cycle;
  slot.filled = true;
  std::uint64_t delay = static_cast<std::uint64_t>(config.delay_cycles);
  if (config.jitter_cycles > 0) {
    delay += std::uniform_int_distribution<std::uint64_t>(0, static_cast<std::uint64_t>(config.jitter_cycles))(random);
  }
  slot.arrival = cycle + delay;
  slot.lost = config.loss > 0.0 && std::uniform_real_distribution<double>(0.0, 1.0)(random) < config.loss;
  ++stats.sent;
  if (slot.lost) ++stats.lost;
  ++pushed;
}

const ClosedLoop::WireSample* ClosedLoop::DelayLine::Received(std::uint64_t cycle) {
  const Slot* newest = nullptr;
  for (const Slot& slot : ring) {
    if (!slot.filled || slot.lost || slot.arrival > cycle) continue;  // empty, lost or still in flight
    if (has_held && slot.index <= held_index) continue;               // not newer than what we have
    if (newest == nullptr || slot.index > newest->index) newest = &slot;
  }
  if (newest != nullptr) {
    ++stats.fresh;
    const std::uint64_t age = cycle - newest->sent_cycle;
    stats.min_age_cycles = std::min(stats.min_age_cycles, age);
    stats.max_age_cycles = std::max(stats.max_age_cycles, age);
    held = newest->sample;
    held_index = newest->index;
    has_held = true;
  }
  if (newest == nullptr && has_held) ++stats.held;
  return has_held ? &held : nullptr;
}

ClosedLoop::ClosedLoop(const ClosedLoopConfig& config)
    : config_(config),
      period_s_(1.0 / config.rate_hz),
      master_law_(config.master_law),
      slave_law_(config.slave_law),
      master_pc_(config.master_passivity),
      slave_pc_(config.slave_passivity),
      master_plant_(config.master_plant),
      slave_plant_(config.slave_plant),
      master_sender_velocity_({config.master_law.dof, config.master_law.velocity_filter_hz}),
      slave_sender_velocity_({config.slave_law.dof, config.slave_law.velocity_filter_hz}) {
  if (!std::isfinite(config.rate_hz) || config.rate_hz <= 0.0) throw Error("closed loop: rate_hz must be > 0");
  if (config.delay_cycles < 0 || config.delay_cycles > 1000) throw Error("closed loop: delay_cycles must be 0..1000");
  const int dof = config.master_law.dof;
  if (config.slave_law.dof != dof || config.master_plant.dof != dof || config.slave_plant.dof != dof ||
      config.master_passivity.dof != dof || config.slave_passivity.dof != dof) {
    throw Error("closed loop: master law, slave law, both plants and both passivity configs must have the same dof");
  }
  if (config.jitter_cycles < 0 || config.jitter_cycles > 1000) {
    throw Error("closed loop: jitter_cycles must be 0..1000");
  }
  if (!(config.loss >= 0.0 && config.loss < 1.0)) throw Error("closed loop: loss must be in [0, 1)");
  const auto slots = static_cast<std::size_t>(config.delay_cycles + config.jitter_cycles) + 1;
  master_to_slave_.ring.assign(slots, DelayLine::Slot{});
  slave_to_master_.ring.assign(slots, DelayLine::Slot{});
  master_to_slave_.random.seed(config.seed);
  slave_to_master_.random.seed(config.seed * 2654435761u + 1u);
}

const ClosedLoopSample& ClosedLoop::Step() {
  device::Reading master_reading;
  device::Reading slave_reading;
  master_plant_.Read(master_reading);
  slave_plant_.Read(slave_reading);

  const int dof = config_.master_law.dof;
  auto energy_of = [dof](const control::PassivityController& pc) {
    DofVector e(dof);
    for (int i = 0; i < dof; ++i) e[i] = pc.state().input_energy_J[static_cast<std::size_t>(i)];
    return e;
  };
  master_to_slave_.Push({master_reading.position_m, master_sender_velocity_.Step(master_reading.position_m, period_s_),
                         master_reading.force_N, energy_of(master_pc_)},
                        cycle_, config_);
  slave_to_master_.Push({slave_reading.position_m, slave_sender_velocity_.Step(slave_reading.position_m, period_s_),
                         slave_reading.force_N, energy_of(slave_pc_)},
                        cycle_, config_);

  auto make_input = [](const device::Reading& own, const WireSample* peer) {
    ThreeChannelLaw::Input input;
    input.position_m = own.position_m;
    input.peer_valid = peer != nullptr;
    if (peer != nullptr) {
      input.peer_position_m = peer->position_m;
      input.peer_velocity_m_per_s = peer->velocity_m_per_s;
      input.peer_force_N = peer->force_N;
    }
    return input;
  };
  const WireSample* from_slave = slave_to_master_.Received(cycle_);
  const WireSample* from_master = master_to_slave_.Received(cycle_);
  ThreeChannelLaw::Output master_out = master_law_.Step(make_input(master_reading, from_slave), period_s_);
  ThreeChannelLaw::Output slave_out = slave_law_.Step(make_input(slave_reading, from_master), period_s_);
  // Time-domain passivity: the law's command passes through the port's controller, as in the processes.
  auto passivate = [this, dof](control::PassivityController& pc, ThreeChannelLaw::Output& out, const WireSample* peer) {
    control::PassivityController::Input in;
    in.force_N = out.command_N;
    in.velocity_m_per_s = out.velocity_m_per_s;
    in.peer_energy_valid = peer != nullptr;
    in.peer_input_energy_J = peer != nullptr ? peer->input_energy_J : ZeroDof(dof);
    const control::PassivityController::Output pc_out = pc.Step(in, period_s_);
    out.command_N = pc_out.force_N;
    return pc_out.acted;
  };
  const bool master_acted = passivate(master_pc_, master_out, from_slave);
  const bool slave_acted = passivate(slave_pc_, slave_out, from_master);

  ClosedLoopSample& s = last_;
  s.cycle = cycle_++;
  s.time_s = master_plant_.time_s();
  s.master_position_m = master_plant_.true_position_m();
  s.slave_position_m = slave_plant_.true_position_m();
  s.master_velocity_m_per_s = master_plant_.true_velocity_m_per_s();
  s.slave_velocity_m_per_s = slave_plant_.true_velocity_m_per_s();
  s.master_command_N = master_out.command_N;
  s.slave_command_N = slave_out.command_N;
  s.operator_target_force_N = master_plant_.OperatorTargetForce();
  s.operator_force_N = master_reading.force_N;
  s.environment_force_N = slave_reading.force_N;
  s.master_penetration_m = master_out.fixture_penetration_m;
  s.slave_penetration_m = slave_out.fixture_penetration_m;
  s.master_status = master_out.status;
  s.slave_status = slave_out.status;
  s.master_faults = master_reading.faults;
  s.slave_faults = slave_reading.faults;
  s.master_observed_J = master_pc_.state().observed_J[0];
  s.slave_observed_J = slave_pc_.state().observed_J[0];
  s.master_pc_acted = master_acted;
  s.slave_pc_acted = slave_acted;
  // The work the commands held over the last interval did on the devices (exact: true positions).
  if (cycle_ > 1) {
    for (int i = 0; i < dof; ++i) {
      network_energy_J_ -= last_master_command_N_[i] * (s.master_position_m[i] - last_master_position_m_[i]) +
                           last_slave_command_N_[i] * (s.slave_position_m[i] - last_slave_position_m_[i]);
    }
  }
  last_master_command_N_ = master_out.command_N;
  last_slave_command_N_ = slave_out.command_N;
  last_master_position_m_ = s.master_position_m;
  last_slave_position_m_ = s.slave_position_m;
  s.network_energy_J = network_energy_J_;

  device::FillCommand(master_out, master_law_.fixture(), master_reading.position_m, master_command_);
  device::FillCommand(slave_out, slave_law_.fixture(), slave_reading.position_m, slave_command_);
  master_plant_.Write(master_command_);
  slave_plant_.Write(slave_command_);
  master_plant_.Update(period_s_);
  slave_plant_.Update(period_s_);
  return last_;
}

std::vector<ClosedLoopSample> ClosedLoop::Run(double duration_s) {
  const int cycles = CyclesFor(duration_s, config_.rate_hz);
  std::vector<ClosedLoopSample> trace;
  trace.reserve(static_cast<std::size_t>(cycles));
  for (int i = 0; i < cycles; ++i) trace.push_back(Step());
  return trace;
}

void ClosedLoop::Run(double duration_s, const std::function<void(const ClosedLoopSample&)>& observer) {
  const int cycles = CyclesFor(duration_s, config_.rate_hz);
  for (int i = 0; i < cycles; ++i) observer(Step());
}

double Value(const ClosedLoopSample& sample, Signal signal, int axis) {
  switch (signal) {
    case Signal::kMasterPosition:
      return sample.master_position_m[axis];
    case Signal::kSlavePosition:
      return sample.slave_position_m[axis];
    case Signal::kTrackingError:
      return sample.slave_position_m[axis] - sample.master_position_m[axis];
    case Signal::kMasterCommand:
      return sample.master_command_N[axis];
    case Signal::kSlaveCommand:
      return sample.slave_command_N[axis];
    case Signal::kOperatorForce:
      return sample.operator_force_N[axis];
    case Signal::kEnvironmentForce:
      return sample.environment_force_N[axis];
    case Signal::kSlavePenetration:
      return sample.slave_penetration_m;
    case Signal::kMasterPenetration:
      return sample.master_penetration_m;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

WindowStats Stats(const std::vector<ClosedLoopSample>& trace, Signal signal, double from_s, double to_s, int axis) {
  WindowStats stats;
  double sum = 0.0;
  double sum_sq = 0.0;
  stats.min = std::numeric_limits<double>::infinity();
  stats.max = -std::numeric_limits<double>::infinity();
  for (const ClosedLoopSample& sample : trace) {
    if (sample.time_s < from_s || sample.time_s >= to_s) continue;
    const double v = Value(sample, signal, axis);
    ++stats.count;
    sum += v;
    sum_sq += v * v;
    stats.min = std::min(stats.min, v);
    stats.max = std::max(stats.max, v);
  }
  if (stats.count == 0) return WindowStats{};
  const double n = static_cast<double>(stats.count);
  stats.mean = sum / n;
  stats.rms = std::sqrt(sum_sq / n);
  stats.std_dev = std::sqrt(std::max(0.0, sum_sq / n - stats.mean * stats.mean));
  stats.peak_to_peak = stats.max - stats.min;
  stats.max_abs = std::max(std::abs(stats.min), std::abs(stats.max));
  return stats;
}

}  // namespace teleop::test
