#include "admittance_device.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "teleop/error.hpp"
#include "teleop/fieldbus/cia402_eds.hpp"

namespace teleop::device {

using fieldbus::Cia402Mode;
using fieldbus::Cia402Status;

VirtualAdmittance::VirtualAdmittance(double mass_kg, double damping_Ns_per_m) : m_(mass_kg), b_(damping_Ns_per_m) {}

void VirtualAdmittance::Reset(double position_m) noexcept {
  x_ = position_m;
  v_ = 0.0;
}

void VirtualAdmittance::Step(double force_N, double h, double max_velocity) noexcept {
  if (!(h > 0.0)) return;
  if (b_ > 0.0) {
    // Exact under a held force: v → F/b with time constant m/b.
    const double v_inf = force_N / b_;
    const double decay = std::exp(-b_ / m_ * h);
    x_ += v_inf * h + (v_ - v_inf) * m_ / b_ * (1.0 - decay);
    v_ = v_inf + (v_ - v_inf) * decay;
  } else {
    x_ += v_ * h + 0.5 * force_N / m_ * h * h;
    v_ += force_N / m_ * h;
  }
  if (max_velocity > 0.0 && std::abs(v_) > max_velocity) v_ = std::copysign(max_velocity, v_);
}

double DefaultMaxTrackingError(const AdmittanceConfig& config) {
  double omega = config.position_loop_bandwidth_rad_per_s;
  if (!(omega > 0.0)) {
    for (int i = 0; i < config.dof && i < config.virtual_mass_kg.size() && i < config.virtual_damping_Ns_per_m.size();
         ++i) {
      const double m = config.virtual_mass_kg[i];
      const double slowest =
          config.bandwidth_ratio *
          std::max(config.virtual_damping_Ns_per_m[i] / m, std::sqrt(std::max(0.0, config.max_stiffness_N_per_m) / m));
      omega = std::max(omega, slowest);
    }
  }
  if (!(omega > 0.0) || !std::isfinite(omega)) return 0.01;
  const double v = config.max_velocity_m_per_s;
  return std::max(1e-3, 2.0 * (v / omega + v * config.cycle_period_s));
}

AdmittanceDevice::AdmittanceDevice(const AdmittanceConfig& config, AdmittancePortFactory ports,
                                   fieldbus::Timebase timebase)
    : config_(config), ports_(std::move(ports)), timebase_(std::move(timebase)) {
  const auto fail = [](const std::string& what) { throw Error("device.admittance: " + what); };
  const int n = config.dof;
  if (n < 1) fail("dof must be >= 1");
  if (config.virtual_mass_kg.size() != n || config.virtual_damping_Ns_per_m.size() != n) {
    fail(fmt::format("virtual_mass_kg and virtual_damping_Ns_per_m need {} values (one per DOF)", n));
  }
  for (int i = 0; i < n; ++i) {
    if (!(config.virtual_mass_kg[i] > 0.0) || !std::isfinite(config.virtual_mass_kg[i])) {
      fail(fmt::format("virtual_mass_kg[{}] must be > 0", i));
    }
    if (!(config.virtual_damping_Ns_per_m[i] >= 0.0) || !std::isfinite(config.virtual_damping_Ns_per_m[i])) {
      fail(fmt::format("virtual_damping_Ns_per_m[{}] must be >= 0", i));
    }
  }
  if (config.mode != Cia402Mode::kCyclicSynchronousPosition && config.mode != Cia402Mode::kCyclicSynchronousVelocity &&
      config.mode != Cia402Mode::kCyclicSynchronousTorque) {
    fail("mode must be position, velocity or torque");
  }
  if (static_cast<int>(config.axes.size()) != n)
    fail(fmt::format("drives: {} entries, dof is {}", config.axes.size(), n));
  if (!(config.max_force_N > 0.0) || !(config.max_velocity_m_per_s > 0.0) || !(config.cycle_period_s > 0.0)) {
    fail("max_force_N, max_velocity_m_per_s and cycle_period_ms must be > 0");
  }
  if (!(config.max_tracking_error_m >= 0.0) || !std::isfinite(config.max_tracking_error_m)) {
    fail("max_tracking_error_m must be >= 0 (0: the default)");
  }
  if (config.tracking_error_cycles < 1) fail("tracking_error_cycles must be >= 1");
  max_tracking_error_m_ =
      config.max_tracking_error_m > 0.0 ? config.max_tracking_error_m : DefaultMaxTrackingError(config);
  for (const AdmittanceAxisConfig& a : config.axes) {
    if (!(a.transmission_m_per_rad > 0.0) || !std::isfinite(a.transmission_m_per_rad)) {
      fail("drives[].transmission_m_per_rad must be > 0");
    }
  }
  for (int i = 0; i < n; ++i) {
    models_.emplace_back(config.virtual_mass_kg[i], config.virtual_damping_Ns_per_m[i]);
  }
  tracking_.assign(static_cast<std::size_t>(n), AdmittanceTracking{});
  history_m_.assign(static_cast<std::size_t>(n), std::array<double, 3>{});
  beyond_run_.assign(static_cast<std::size_t>(n), 0);
  anchored_.assign(static_cast<std::size_t>(n), false);
  caps_.dof = n;
  caps_.rendering = Rendering::kActiveForce;
  caps_.max_force_N = DofVector::Constant(n, config.max_force_N);
  caps_.measures_velocity = true;
  caps_.measures_force = false;
  force_N_ = DofVector::Zero(n);
  rendered_N_ = DofVector::Zero(n);
  if (!ports_) {
    const fieldbus::CanPortConfig can = config.can;
    ports_ = [can](const transport::CanReceiveOptions& options) { return fieldbus::OpenCanPort(can, options); };
  }
}

AdmittanceDevice::~AdmittanceDevice() = default;

const char* ToString(AdmittanceFaultSource source) noexcept {
  switch (source) {
    case AdmittanceFaultSource::kNone:
      return "none";
    case AdmittanceFaultSource::kDrive:
      return "drive";
    case AdmittanceFaultSource::kTracking:
      return "tracking";
    case AdmittanceFaultSource::kCommand:
      return "command";
    case AdmittanceFaultSource::kSync:
      return "SYNC";
  }
  return "?";
}

void AdmittanceDevice::Fault(std::uint32_t& faults, std::uint32_t bits, AdmittanceFaultSource source, int axis,
                             Cia402Status status) noexcept {
  faults |= bits;
  if (fault_source_.load(std::memory_order_relaxed) != AdmittanceFaultSource::kNone) return;
  fault_axis_.store(axis, std::memory_order_relaxed);
  fault_status_.store(status, std::memory_order_relaxed);
  const bool emcy = status == Cia402Status::kFault && axis >= 0 && static_cast<std::size_t>(axis) < drives_.size();
  fault_emcy_code_.store(emcy ? drives_[static_cast<std::size_t>(axis)]->last_emergency().error_code : 0,
                         std::memory_order_relaxed);
  fault_source_.store(source, std::memory_order_release);
}

std::string AdmittanceDevice::FaultText() const {
  const AdmittanceFaultSource source = fault_source_.load(std::memory_order_acquire);
  const int axis = fault_axis_.load(std::memory_order_relaxed);
  switch (source) {
    case AdmittanceFaultSource::kNone:
      return {};
    case AdmittanceFaultSource::kDrive: {
      if (axis < 0) return "no drive configured";
      const fieldbus::Cia402DriveConfig& d = config_.axes[static_cast<std::size_t>(axis)].drive;
      return fmt::format("axis {} (node {}): {}", axis, d.node_id,
                         fieldbus::DescribeFault(d, fault_status_.load(std::memory_order_relaxed),
                                                 fault_emcy_code_.load(std::memory_order_relaxed)));
    }
    case AdmittanceFaultSource::kTracking:
      return fmt::format(
          "axis {}: the drive's joint did not follow the virtual mass (beyond max_tracking_error_m, "
          "{:.3f} mm, for tracking_error_cycles)",
          axis, max_tracking_error_m_ * 1e3);
    case AdmittanceFaultSource::kCommand:
      return "a non-finite or wrongly sized force command";
    case AdmittanceFaultSource::kSync:
      return "the bus refused the cycle's SYNC (bus-off or a full transmit queue)";
  }
  return {};
}

void AdmittanceDevice::Configure() {
  drives_.clear();
  drive_ports_.clear();
  sync_.reset();
  for (int i = 0; i < config_.dof; ++i) {
    const AdmittanceAxisConfig& a = config_.axes[static_cast<std::size_t>(i)];
    fieldbus::Cia402DriveConfig c = a.drive;
    c.mode = config_.mode;
    c.rpdos = fieldbus::Cia402DriveConfig::DefaultRpdos(config_.mode);
    c.produce_sync = false;  // one SYNC for the bus, at the start of each cycle (docs/cia402.md)
    c.cycle_period_s = config_.cycle_period_s;
    c.max_velocity_rad_per_s = config_.max_velocity_m_per_s / a.transmission_m_per_rad;
    fieldbus::ApplyEds(c);
    drive_ports_.push_back(ports_(fieldbus::Cia402Drive::ReceiveOptions(c)));
    drives_.push_back(std::make_unique<fieldbus::Cia402Drive>(c, *drive_ports_.back(), timebase_));
    drives_.back()->Configure();
  }
  sync_ = std::make_unique<fieldbus::canopen::SyncProducer>(*drive_ports_.front());
  taken_.assign(drives_.size(), Taken{});
}

void AdmittanceDevice::Activate() {
  if (drives_.empty()) throw Error("device.admittance: Configure() first");
  for (int i = 0; i < config_.dof; ++i) {
    auto& d = *drives_[static_cast<std::size_t>(i)];
    d.Activate();
    const double t = config_.axes[static_cast<std::size_t>(i)].transmission_m_per_rad;
    // Position mode: the virtual mass starts where the joint is (the drive's target was set to it).
    const auto k = static_cast<std::size_t>(i);
    const bool position_mode = config_.mode == Cia402Mode::kCyclicSynchronousPosition;
    models_[k].Reset(position_mode ? d.position_target_rad() * t : 0.0);
    history_m_[k].fill(models_[k].position_m());
    tracking_[k] = AdmittanceTracking{};
    tracking_[k].measured_position_m = models_[k].position_m();
    beyond_run_[k] = 0;
    // Velocity mode: the virtual position is set to the joint's at the first fresh reading (Read).
    anchored_[k] = position_mode;
  }
  tracking_fault_ = false;
  force_N_.setZero();
  faults_ = kFaultNone;
  fault_axis_.store(-1, std::memory_order_relaxed);
  fault_status_.store(Cia402Status::kOk, std::memory_order_relaxed);
  fault_emcy_code_.store(0, std::memory_order_relaxed);
  fault_source_.store(AdmittanceFaultSource::kNone, std::memory_order_release);
  safe_ = true;
  active_ = true;
}

void AdmittanceDevice::Deactivate() noexcept {
  SetSafe();
  if (active_ && fault_source() != AdmittanceFaultSource::kNone) {
    spdlog::error("device.admittance: the first fault since Activate ({}): {}", ToString(fault_source()), FaultText());
  }
  if (active_) {
    for (int i = 0; i < config_.dof; ++i) {
      const AdmittanceTracking& a = tracking_[static_cast<std::size_t>(i)];
      if (config_.mode == Cia402Mode::kCyclicSynchronousTorque) {
        spdlog::info("device.admittance: axis {}: torque mode, the drive's measured position {:.6f} m", i,
                     a.measured_position_m);
        continue;
      }
      spdlog::info(
          "device.admittance: axis {}: drive's measured position {:.6f} m, virtual {:.6f} m; tracking error max {:.3f} "
          "mm (bound {:.3f} mm), {} cycles beyond, {} tracking faults",
          i, a.measured_position_m, models_[static_cast<std::size_t>(i)].position_m(), a.max_error_m * 1e3,
          max_tracking_error_m_ * 1e3, a.cycles_beyond, a.faults);
      if (a.faults > 0) {
        spdlog::error("device.admittance: axis {}: the drive did not follow the virtual mass (kFaultDriver)", i);
      }
    }
  }
  active_ = false;
  for (auto& d : drives_) (void)d->Deactivate();
}

void AdmittanceDevice::Exchange() noexcept {
  // TPDOs in (sampled at the previous SYNC), every drive's, before the SYNC...
  for (std::size_t k = 0; k < drives_.size(); ++k) taken_[k].status = drives_[k]->Read(taken_[k].reading);
  // ...then one SYNC for every drive: it applies the RPDOs the previous cycle's Update() queued.
  // A refused SYNC is the exchange's own fault (kSync), not a drive's.
  if (sync_ && sync_->Send() != transport::CanWriteStatus::kOk) {
    Fault(faults_, kFaultCommunication, AdmittanceFaultSource::kSync);
  }
}

void AdmittanceDevice::TrackAxis(std::size_t k, double measured_m, std::uint32_t& faults) noexcept {
  AdmittanceTracking& a = tracking_[k];
  a.measured_position_m = measured_m;
  if (!anchored_[k]) {
    models_[k].Reset(measured_m);
    history_m_[k].fill(measured_m);
    anchored_[k] = true;
    return;
  }
  if (!active_) return;
  // The reading was sampled at the SYNC of the previous cycle, where the joint had followed the target that
  // SYNC's predecessor applied: the virtual position Read reported two cycles ago (history_m_[k][2]).
  a.error_m = std::abs(measured_m - history_m_[k][2]);
  a.max_error_m = std::max(a.max_error_m, a.error_m);
  if (a.error_m <= max_tracking_error_m_) {
    beyond_run_[k] = 0;
    return;
  }
  ++a.cycles_beyond;
  if (++beyond_run_[k] >= config_.tracking_error_cycles) {
    if (beyond_run_[k] == config_.tracking_error_cycles) ++a.faults;
    tracking_fault_ = true;
    Fault(faults, kFaultDriver, AdmittanceFaultSource::kTracking, static_cast<int>(k));
  }
}

void AdmittanceDevice::Read(Reading& out) noexcept {
  const int n = config_.dof;
  out.position_m = DofVector::Zero(n);
  out.velocity_m_per_s = DofVector::Zero(n);
  out.force_N = DofVector::Zero(n);
  out.rendered_force_N = rendered_N_;
  out.warnings = kWarningNone;
  std::uint32_t faults = faults_;
  faults_ = kFaultNone;
  for (int i = 0; i < n && i < static_cast<int>(drives_.size()); ++i) {
    const auto k = static_cast<std::size_t>(i);
    const fieldbus::Cia402Reading& r = taken_[k].reading;
    const Cia402Status s = taken_[k].status;
    // What the exchange took in is read once: a second Read sees no new data, as the drive's own Read would.
    if (s == Cia402Status::kOk) taken_[k].status = Cia402Status::kNoNewData;
    const double t = config_.axes[k].transmission_m_per_rad;
    if (config_.mode == Cia402Mode::kCyclicSynchronousTorque) {
      // Torque mode: no virtual dynamics; the law closes on the joint as the drive measures it.
      tracking_[k].measured_position_m = r.position_rad * t;
      out.position_m[i] = r.position_rad * t;
      out.velocity_m_per_s[i] = r.velocity_rad_per_s * t;
    } else {
      if (s == Cia402Status::kOk) TrackAxis(k, r.position_rad * t, faults);
      // The admittance's commanded state: the law and the fixture close their loop on the virtual mass.
      out.position_m[i] = models_[k].position_m();
      out.velocity_m_per_s[i] = models_[k].velocity_m_per_s();
    }
    switch (s) {
      case Cia402Status::kOk:
      case Cia402Status::kNoNewData:
        break;
      case Cia402Status::kFault:
      case Cia402Status::kNotEnabled:
      case Cia402Status::kNotActive:
      case Cia402Status::kWrongMode:
        Fault(faults, kFaultDriver, AdmittanceFaultSource::kDrive, i, s);
        break;
      default:
        Fault(faults, kFaultCommunication, AdmittanceFaultSource::kDrive, i, s);
        break;
    }
  }
  if (drives_.empty()) Fault(faults, kFaultDriver, AdmittanceFaultSource::kDrive);
  out.faults = faults;
}

void AdmittanceDevice::Write(const Command& command) noexcept {
  const int n = config_.dof;
  if (command.force_N.size() != n || !command.force_N.allFinite()) {
    Fault(faults_, kFaultDriver, AdmittanceFaultSource::kCommand);
    force_N_.setZero();
    return;
  }
  force_N_ = command.force_N.cwiseMax(-config_.max_force_N).cwiseMin(config_.max_force_N);
  safe_ = false;
}

void AdmittanceDevice::Update(double period_s) noexcept {
  if (!active_) return;
  for (int i = 0; i < config_.dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double t = config_.axes[k].transmission_m_per_rad;
    VirtualAdmittance& m = models_[k];
    if (config_.mode == Cia402Mode::kCyclicSynchronousTorque) {
      // The law's force is the drive's torque through the transmission (F ẋ = τ θ̇: τ = F · r); the safe state 0.
      rendered_N_[i] = safe_ ? 0.0 : force_N_[i];
      const Cia402Status s = drives_[k]->WriteTorque_Nm(rendered_N_[i] * t);
      if (s == Cia402Status::kWriteFailed || s == Cia402Status::kBusOff || s == Cia402Status::kHeartbeatLost) {
        Fault(faults_, kFaultCommunication, AdmittanceFaultSource::kDrive, i, s);
      } else if (s == Cia402Status::kFault) {
        Fault(faults_, kFaultDriver, AdmittanceFaultSource::kDrive, i, s);
      }
      continue;
    }
    if (safe_) {
      m.Reset(m.position_m());  // hold: the mass stops where it is
      rendered_N_[i] = 0.0;
    } else {
      m.Step(force_N_[i], period_s, config_.max_velocity_m_per_s);
      rendered_N_[i] = force_N_[i];
    }
    auto& h = history_m_[k];
    h[2] = h[1];
    h[1] = h[0];
    h[0] = m.position_m();
    const Cia402Status s = config_.mode == Cia402Mode::kCyclicSynchronousPosition
                               ? drives_[k]->WritePosition_rad(m.position_m() / t)
                               : drives_[k]->WriteVelocity_rad_per_s(m.velocity_m_per_s() / t);
    if (s == Cia402Status::kWriteFailed || s == Cia402Status::kBusOff || s == Cia402Status::kHeartbeatLost) {
      Fault(faults_, kFaultCommunication, AdmittanceFaultSource::kDrive, i, s);
    } else if (s == Cia402Status::kFault) {
      Fault(faults_, kFaultDriver, AdmittanceFaultSource::kDrive, i, s);
    }
  }
}

void AdmittanceDevice::SetSafe() noexcept {
  safe_ = true;
  force_N_.setZero();
  if (tracking_fault_) {
    // The joint did not follow: hold the virtual mass where the joint is, so the drive stops pushing towards a
    // position it cannot reach.
    for (std::size_t k = 0; k < models_.size(); ++k) {
      models_[k].Reset(tracking_[k].measured_position_m);
      history_m_[k].fill(tracking_[k].measured_position_m);
      beyond_run_[k] = 0;
    }
    tracking_fault_ = false;
  }
}

}  // namespace teleop::device
