#pragma once

// The admittance backend's device (private header): a virtual mass-damper per axis, m_v ẍ + b_v ẋ = F, driven by
// the force the law commands; its position (mode 8) or velocity (mode 9) is the target of a CiA 402 drive. The
// drive's own position loop makes the joint follow, so the slave behaves as the virtual dynamics — the model the
// start-up stability check uses — as long as that loop is much faster than the virtual dynamics (b_v/m_v) and the
// coupling (docs/cia402.md, "Admittance backend").
//
// What Read reports: the virtual mass's own state (position and velocity), i.e. the admittance's COMMANDED state,
// which the device integrates every cycle; the law and the fixture close their loop on it, as admittance control
// does, and that is the loop the start-up check models. The drives' measured positions are not fed to the law (they
// are the virtual mass two cycles late: the target takes effect at the next SYNC, the position sampled at the
// following SYNC is read a cycle later; closing the law on them lowers the fixture limit to 0.18 of the prediction).
// Instead every cycle checks them against the virtual mass of two cycles earlier: an error beyond
// max_tracking_error_m for tracking_error_cycles consecutive cycles (a stalled, blocked or too slow drive) is
// kFaultDriver, and the pair goes to the safe state. The measured positions and the largest tracking error are in
// measured_position_m / tracking() and in the log at Deactivate.
//
// Torque mode (10), for a torque-controlled axis on the same drives: no virtual mass; the law's force goes to the
// drive as torque through the transmission and the reading is the drive's measured position and velocity; the
// stability model is then the axis itself, (virtual_mass_kg, virtual_damping_Ns_per_m) as its mass and damping at the
// tool; no tracking check.

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "teleop/device/bus_exchange.hpp"
#include "teleop/device/device.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/canopen_sync_producer.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/types.hpp"

namespace teleop::device {

/// m ẍ + b ẋ = F with F held over each step, integrated exactly (zero-order hold): no step-size limit.
class VirtualAdmittance {
 public:
  VirtualAdmittance(double mass_kg, double damping_Ns_per_m);
  void Reset(double position_m) noexcept;
  /// Advances by `h` seconds under `force_N`; the speed is clamped to ±max_velocity (0: no clamp).
  void Step(double force_N, double h, double max_velocity) noexcept;
  double position_m() const noexcept { return x_; }
  double velocity_m_per_s() const noexcept { return v_; }

 private:
  double m_;
  double b_;
  double x_ = 0.0;
  double v_ = 0.0;
};

struct AdmittanceAxisConfig {
  fieldbus::Cia402DriveConfig drive{};  ///< node_id, scaling, heartbeat, eds_file …; mode and PDOs set by the device.
  double transmission_m_per_rad = 1.0;  ///< Axis metres per joint radian (a capstan radius, a lead / 2π).
};

struct AdmittanceConfig {
  int dof = 1;
  DofVector virtual_mass_kg;           ///< m_v per axis, > 0.
  DofVector virtual_damping_Ns_per_m;  ///< b_v per axis, >= 0 (> 0 in velocity mode is not required).
  /// 8 or 9: the drives follow the virtual mass-damper. 10 (torque): no virtual dynamics; the law's force is the
  /// drives' torque (τ = F · transmission), the reading their measured state, and (virtual_mass_kg,
  /// virtual_damping_Ns_per_m) are the axis's own mass and damping at the tool (J/r², b/r²), the stability model.
  fieldbus::Cia402Mode mode = fieldbus::Cia402Mode::kCyclicSynchronousPosition;
  double max_force_N = 50.0;          ///< The law's force is clamped to it (the virtual actuator's limit).
  double max_velocity_m_per_s = 0.5;  ///< The virtual mass's speed limit (and the drives' target limit).
  /// The drives' position-loop bandwidth (rad/s, from their tuning), for the assumption check of the model; 0: not
  /// known, the check is not applicable.
  double position_loop_bandwidth_rad_per_s = 0.0;
  /// The assumption: the loop at least this many times faster than b_v/m_v and than sqrt(K/m_v) (docs/cia402.md).
  double bandwidth_ratio = 10.0;
  /// K: the stiffest spring the virtual mass meets (the coupling's kp plus the fixture's stiffness), N/m; 0: only
  /// b_v/m_v is checked.
  double max_stiffness_N_per_m = 0.0;
  double cycle_period_s = 0.001;
  /// The largest |drive's measured position − virtual position two cycles earlier| allowed, m; 0: the default,
  /// DefaultMaxTrackingError() (derived from the assumption the stability check makes).
  double max_tracking_error_m = 0.0;
  /// How many consecutive cycles beyond max_tracking_error_m make kFaultDriver, >= 1.
  int tracking_error_cycles = 10;
  fieldbus::CanPortConfig can{};
  std::vector<AdmittanceAxisConfig> axes;  ///< One per DOF.
};

/// The default tracking bound: a drive that meets the stability model's assumption (a first-order position loop of
/// bandwidth ω ≥ bandwidth_ratio · max(b_v/m_v, sqrt(K/m_v)); ω = position_loop_bandwidth_rad_per_s when given, else
/// the slowest loop the assumption admits) follows a ramp at the speed limit v_max with the lag v_max/ω, plus one
/// cycle of timing (v_max · T); the default is twice that, at least 1 mm (no spring and no damping: 10 mm).
double DefaultMaxTrackingError(const AdmittanceConfig& config);

/// What the device checked of the drives, per axis (not reset by Read; reset by Activate).
struct AdmittanceTracking {
  double measured_position_m = 0.0;  ///< The drive's last measured position (axis metres).
  double error_m = 0.0;              ///< Last |measured − virtual two cycles earlier|.
  double max_error_m = 0.0;          ///< The largest since Activate.
  std::uint64_t cycles_beyond = 0;   ///< Cycles beyond the bound since Activate.
  std::uint64_t faults = 0;          ///< Times the persistence was reached (kFaultDriver set).
};

/// Opens the port of one drive (tests: the in-process emulated bus).
using AdmittancePortFactory =
    std::function<std::unique_ptr<fieldbus::CanPort>(const transport::CanReceiveOptions& options)>;

/// What set a fault bit first since Activate (Reading::faults carries the bits; Deactivate logs it with the axis):
/// kDrive a drive's status or a refused RPDO, kTracking the tracking check, kCommand a non-finite or wrongly sized
/// command, kSync the cycle's SYNC could not be sent (the bus exchange itself, not a drive).
enum class AdmittanceFaultSource : std::uint8_t { kNone, kDrive, kTracking, kCommand, kSync };
const char* ToString(AdmittanceFaultSource source) noexcept;

class AdmittanceDevice final : public Device, public BusExchange {
 public:
  /// Validates (throws teleop::Error naming the key); no I/O. `ports` defaults to OpenCanPort(config.can, …).
  explicit AdmittanceDevice(const AdmittanceConfig& config, AdmittancePortFactory ports = {},
                            fieldbus::Timebase timebase = fieldbus::Timebase::Steady());
  ~AdmittanceDevice() override;

  const Capabilities& capabilities() const noexcept override { return caps_; }
  const std::string& name() const noexcept override { return name_; }
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  /// The cycle's bus exchange: every drive's TPDOs in, then the one SYNC (it applies the RPDOs Update() queued).
  void Exchange() noexcept override;
  /// What the last Exchange() took in, through the virtual mass and the tracking check; no bus I/O.
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  const VirtualAdmittance& axis_model(int axis) const { return models_.at(static_cast<std::size_t>(axis)); }
  const fieldbus::Cia402Drive& drive(int axis) const { return *drives_.at(static_cast<std::size_t>(axis)); }
  /// The drive's measured position and the tracking check of `axis` (the operator's view of the real joint).
  const AdmittanceTracking& tracking(int axis) const { return tracking_.at(static_cast<std::size_t>(axis)); }
  double measured_position_m(int axis) const { return tracking(axis).measured_position_m; }
  double max_tracking_error_m() const noexcept { return max_tracking_error_m_; }
  /// The first fault's source since Activate, and its axis (kDrive, kTracking; -1 otherwise).
  AdmittanceFaultSource fault_source() const noexcept { return fault_source_.load(std::memory_order_acquire); }
  int fault_axis() const noexcept { return fault_axis_.load(std::memory_order_relaxed); }
  /// kDrive: the drive's status that set it (kOk for a refused RPDO reported by Update as kWriteFailed, etc.).
  fieldbus::Cia402Status fault_status() const noexcept { return fault_status_.load(std::memory_order_relaxed); }
  /// The first fault since Activate in words: its source, the axis and drive node, and what the drive's status
  /// says ("axis 0 (node 1): the drive stopped answering (no TPDO for stale_after_ms, 50 ms)").
  std::string FaultText() const override;

 private:
  /// One drive's part of the last Exchange(): its status and reading (kOk becomes kNoNewData once Read).
  struct Taken {
    fieldbus::Cia402Status status = fieldbus::Cia402Status::kNotActive;
    fieldbus::Cia402Reading reading{};
  };
  /// Position and velocity modes: the tracking check of axis `k` on a fresh measurement (anchors the virtual
  /// position to the joint's at the first one); sets kFaultDriver in `faults` once the bound holds long enough.
  void TrackAxis(std::size_t k, double measured_m, std::uint32_t& faults) noexcept;
  /// Sets `bits` in `faults` and names the source when it is the first since Activate.
  void Fault(std::uint32_t& faults, std::uint32_t bits, AdmittanceFaultSource source, int axis = -1,
             fieldbus::Cia402Status status = fieldbus::Cia402Status::kOk) noexcept;

  AdmittanceConfig config_;
  AdmittancePortFactory ports_;
  fieldbus::Timebase timebase_;
  Capabilities caps_{};
  std::string name_ = "admittance";
  std::vector<VirtualAdmittance> models_;
  std::vector<AdmittanceTracking> tracking_;
  std::vector<std::array<double, 3>> history_m_;  ///< Virtual position after the last three Updates, newest first.
  std::vector<int> beyond_run_;                   ///< Consecutive cycles beyond the bound.
  std::vector<bool> anchored_;                    ///< Velocity mode: the virtual position set to the joint's.
  double max_tracking_error_m_ = 0.0;
  bool tracking_fault_ = false;
  std::vector<std::unique_ptr<fieldbus::CanPort>> drive_ports_;
  std::vector<std::unique_ptr<fieldbus::Cia402Drive>> drives_;
  std::unique_ptr<fieldbus::CanPort> sync_port_;
  std::unique_ptr<fieldbus::canopen::SyncProducer> sync_;
  std::vector<Taken> taken_;  ///< Per drive, sized at Configure().
  DofVector force_N_;
  DofVector rendered_N_;
  std::uint32_t faults_ = kFaultNone;
  // Latched by the cycle at the first fault since Activate, for FaultText on another thread (the event log): the
  // axis, status and EMCY code first, then the source (release), which FaultText reads first (acquire).
  std::atomic<AdmittanceFaultSource> fault_source_{AdmittanceFaultSource::kNone};
  std::atomic<int> fault_axis_{-1};
  std::atomic<fieldbus::Cia402Status> fault_status_{fieldbus::Cia402Status::kOk};
  std::atomic<std::uint16_t> fault_emcy_code_{0};  ///< kFault: the drive's newest EMCY code then (0: none).
  bool active_ = false;
  bool safe_ = true;
};

struct AnalysisModel;
/// The stability check's model of the slave (admittance_backend.cpp).
AnalysisModel AdmittanceModel(const AdmittanceConfig& config);

}  // namespace teleop::device
