// The arm's joints on CiA 402 drives (cia402_joint_bus.hpp).

#include "cia402_joint_bus.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/proto/can/bus_load.hpp"

namespace teleop::device::arm {

using fieldbus::Cia402Status;

class Cia402JointBus::Joint final : public JointActuator {
 public:
  Joint(const Cia402JointConfig& config, fieldbus::Cia402Drive& drive) : config_(config), drive_(drive) {}

  void Read(JointSample& out) noexcept override { out = sample_; }
  void WriteTorque(double torque_Nm) noexcept override { torque_Nm_ = torque_Nm; }

  /// The drive's reading into the joint's sample; a fault found here is latched until ClearFault.
  void TakeIn(bool in_grace) noexcept {
    fieldbus::Cia402Reading r;
    Cia402Status status = drive_.Read(r);
    if (status == Cia402Status::kOk) awaiting_fresh_ = false;
    if (status == Cia402Status::kStale && awaiting_fresh_ && in_grace) status = Cia402Status::kNoNewData;
    if (status == Cia402Status::kOk || status == Cia402Status::kNoNewData) SetPosition(r);
    if (sample_.fault || !active_) return;
    switch (status) {
      case Cia402Status::kOk:
      case Cia402Status::kNoNewData:
        break;
      case Cia402Status::kFault: {
        // The EMCY's error code is the drive's 0x603F: 0x4xxx temperature, 0x81xx communication (0x8130: the
        // drive's consumer of the host's heartbeat fired), the others the drive's own.
        const std::uint16_t code = drive_.last_emergency().error_code;
        Latch((code & 0xF000u) == 0x4000u   ? JointFaultKind::kOverTemperature
              : (code & 0xFF00u) == 0x8100u ? JointFaultKind::kNoReply
                                            : JointFaultKind::kDriver,
              code != 0 ? code : kCia402FaultHost + static_cast<std::uint32_t>(status));
        break;
      }
      case Cia402Status::kStale:
      case Cia402Status::kHeartbeatLost:
      case Cia402Status::kBusOff:
      case Cia402Status::kWriteFailed:
        Latch(JointFaultKind::kNoReply, kCia402FaultHost + static_cast<std::uint32_t>(status));
        break;
      case Cia402Status::kNotEnabled:
      case Cia402Status::kNotActive:
      case Cia402Status::kWrongMode:
        Latch(JointFaultKind::kDriver, kCia402FaultHost + static_cast<std::uint32_t>(status));
        break;
    }
  }
  /// This cycle's RPDO (applied at the next SYNC): the joint torque on the drive's side (quick stop once faulted).
  void Send() noexcept {
    const Cia402Status s = drive_.WriteTorque_Nm(config_.sign * torque_Nm_ / config_.gear_ratio);
    if (s == Cia402Status::kWriteFailed && !sample_.fault && active_) {
      Latch(JointFaultKind::kNoReply, kCia402FaultHost + static_cast<std::uint32_t>(s));
    }
  }
  void SetFromDrive(double drive_position_rad, double drive_velocity_rad_per_s) noexcept {
    sample_.position = config_.offset_rad + config_.sign * drive_position_rad / config_.gear_ratio;
    sample_.velocity = config_.sign * drive_velocity_rad_per_s / config_.gear_ratio;
  }
  void Start() noexcept {
    sample_.fault = false;
    sample_.fault_code = 0;
    torque_Nm_ = 0.0;
    awaiting_fresh_ = true;
    active_ = true;
  }
  void Stop() noexcept { active_ = false; }
  /// Its bus refused the cycle's SYNC or heartbeat (`code`: kCia402FaultSync, kCia402FaultHeartbeat).
  void LatchBus(std::uint32_t code) noexcept {
    if (!sample_.fault) Latch(JointFaultKind::kNoReply, code);
  }
  bool fault() const noexcept { return sample_.fault; }
  fieldbus::Cia402Drive& drive() noexcept { return drive_; }

 private:
  void SetPosition(const fieldbus::Cia402Reading& r) noexcept {
    SetFromDrive(r.position_rad, r.velocity_rad_per_s);
    sample_.torque_Nm = config_.sign * config_.gear_ratio * r.torque_Nm;
  }
  void Latch(JointFaultKind kind, std::uint32_t code) noexcept {
    sample_.fault = true;
    sample_.fault_kind = kind;
    sample_.fault_code = code;
  }

  Cia402JointConfig config_;
  fieldbus::Cia402Drive& drive_;
  JointSample sample_;
  double torque_Nm_ = 0.0;
  bool awaiting_fresh_ = true;
  bool active_ = false;
};

int Cia402JointBusConfig::bus_count() const noexcept {
  int n = 0;
  for (const Cia402JointConfig& j : joints) n = std::max(n, j.bus + 1);
  return n;
}

fieldbus::Cia402DriveConfig Cia402DriveConfigOf(const Cia402JointBusConfig& config, std::size_t i) {
  const Cia402JointConfig& j = config.joints[i];
  fieldbus::Cia402DriveConfig d;
  d.node_id = j.node_id;
  d.produce_sync = false;  // one SYNC per bus, the JointBus's (StartCycle)
  d.cycle_period_s = 1.0 / config.rate_hz;
  // The host heartbeat is the bus's (Cia402JointBus::heartbeats_), and its consumer in the drive is switched on at
  // Activate and off at Deactivate by the JointBus: Configure writes it off (a consumer left by an earlier session).
  d.host_node_id = config.host_node_id;
  d.host_heartbeat_period_ms = 0.0;
  d.drive_heartbeat_period_ms = config.drive_heartbeat_period_ms;
  d.heartbeat_timeout_ms = config.heartbeat_timeout_ms;
  d.drive_consumer_timeout_ms = 0.0;
  d.sdo.timeout_ms = config.sdo_timeout_ms;
  d.mode = fieldbus::Cia402Mode::kCyclicSynchronousTorque;
  d.scaling.rated_torque_Nm = j.rated_torque_Nm;
  d.scaling.position_rad_per_count = j.position_rad_per_count;
  d.scaling.velocity_rad_per_s_per_unit = j.velocity_rad_per_s_per_unit;
  d.max_torque_Nm = j.max_torque_Nm;
  d.state_timeout_ms = config.activate_timeout_ms;
  d.stale_after_ms = config.stale_after_ms;
  d.read_device_info = false;  // teleop-drive info reads it; seven drives' identities are not the arm's set-up
  return d;
}

namespace {

double FrameTime_s(int data_bytes, double bitrate) {
  return proto::can::ClassicFrameBits(false, static_cast<std::size_t>(data_bytes)) / bitrate;
}

/// One drive's cyclic frames (its RPDOs and TPDOs) per cycle, s.
double DriveCycleTime_s(const fieldbus::Cia402DriveConfig& d, double bitrate) {
  double t = 0.0;
  for (const auto& m : d.rpdos) t += FrameTime_s(fieldbus::canopen::PdoLength(m), bitrate);
  for (const auto& m : d.tpdos) t += FrameTime_s(fieldbus::canopen::PdoLength(m), bitrate);
  return t;
}

}  // namespace

void CheckCia402BusLoad(const Cia402JointBusConfig& config, const std::string& where) {
  const double rate = config.rate_hz;
  if (rate <= 0.0 || config.joints.empty()) return;
  const double bitrate = config.nominal_bitrate_bit_per_s;
  const double sync_s = FrameTime_s(0, bitrate);
  const double heartbeat_s = FrameTime_s(1, bitrate);
  const double per_drive_s = DriveCycleTime_s(Cia402DriveConfigOf(config, 0), bitrate);
  const double per_drive_load =
      per_drive_s * rate +
      (config.drive_heartbeat_period_ms > 0.0 ? heartbeat_s / (config.drive_heartbeat_period_ms * 1e-3) : 0.0);
  const double bus_load =
      sync_s * rate +
      (config.host_heartbeat_period_ms > 0.0 ? heartbeat_s / (config.host_heartbeat_period_ms * 1e-3) : 0.0);
  const int n = static_cast<int>(config.joints.size());
  const int fit = static_cast<int>(std::floor((config.max_bus_load - bus_load) / per_drive_load));
  for (int b = 0; b < config.bus_count(); ++b) {
    int drives = 0;
    for (const Cia402JointConfig& j : config.joints) drives += j.bus == b ? 1 : 0;
    const double load = bus_load + drives * per_drive_load;
    if (load <= config.max_bus_load) continue;
    // The highest rate at which this bus fits: load(rate) = rate·(sync + drives·per_drive) + heartbeats.
    const double hb = load - rate * (sync_s + drives * per_drive_s);
    const double max_rate = (config.max_bus_load - hb) / (sync_s + drives * per_drive_s);
    throw Error(fmt::format(
        "{}: bus {} carries {} CiA 402 drives at {} Hz (a SYNC, and per drive its RPDO and {} TPDOs each cycle, "
        "classic CAN at {:.0f} kbit/s): load {:.2f}, above the budget {:.2f} (max_bus_load); what fits: {} drives "
        "per bus at {} Hz ({} buses for {} joints), or a rate of at most {:.0f} Hz on this bus",
        where, b, drives, rate, Cia402DriveConfigOf(config, 0).tpdos.size(), bitrate / 1e3, load, config.max_bus_load,
        std::max(fit, 0), rate, fit > 0 ? (n + fit - 1) / fit : n, n, std::floor(std::max(max_rate, 0.0))));
  }
}

Cia402JointBus::Cia402JointBus(Cia402JointBusConfig config, std::unique_ptr<Cia402Plant> plant,
                               std::vector<std::string> joint_names)
    : config_(std::move(config)),
      plant_(std::move(plant)),
      timebase_(plant_ != nullptr ? plant_->timebase() : fieldbus::Timebase::Steady()),
      setup_timebase_{timebase_.now_ns,
                      [this](std::uint64_t ns) {
                        timebase_.wait_ns(ns);
                        ServiceHeartbeats();
                      }},
      names_(std::move(joint_names)) {
  if (config_.joints.empty()) throw Error("arm: actuators cia402 with no joints");
  const double consumer_ms = config_.drive_consumer_timeout_ms;
  if (!(consumer_ms >= 0.0) || consumer_ms > 65535.0 ||
      (consumer_ms > 0.0 &&
       !(consumer_ms > config_.host_heartbeat_period_ms && config_.host_heartbeat_period_ms > 0.0))) {
    throw Error(fmt::format(
        "arm: cia402.drive_consumer_timeout_ms {:g} must be 0 (off) or more than the host's heartbeat period "
        "cia402.host_heartbeat_period_ms {:g} (> 0), at most 65535",
        consumer_ms, config_.host_heartbeat_period_ms));
  }
  const int buses = config_.bus_count();
  if (!config_.simulated && plant_ == nullptr && static_cast<int>(config_.buses.size()) < buses) {
    throw Error(fmt::format("arm: cia402 joints use {} buses, cia402.buses has {}", buses, config_.buses.size()));
  }
  for (std::size_t i = 0; i < config_.joints.size(); ++i) {
    const Cia402JointConfig& j = config_.joints[i];
    if (!(j.gear_ratio > 0.0) || !std::isfinite(j.gear_ratio) || (j.sign != 1.0 && j.sign != -1.0)) {
      throw Error(fmt::format("arm: {}: gear_ratio must be > 0 and sign +1 or -1", Where(i)));
    }
    for (std::size_t k = 0; k < i; ++k) {
      if (config_.joints[k].bus == j.bus && config_.joints[k].node_id == j.node_id) {
        throw Error(fmt::format("arm: {} and joint {} share node {} on bus {}", Where(i), k + 1, j.node_id, j.bus));
      }
    }
    if (j.node_id == config_.host_node_id && config_.host_heartbeat_period_ms > 0.0) {
      throw Error(fmt::format("arm: {}: node {} is the host's heartbeat node-ID", Where(i), j.node_id));
    }
  }
  first_joint_of_bus_.assign(static_cast<std::size_t>(buses), -1);
  for (std::size_t i = 0; i < config_.joints.size(); ++i) {
    const fieldbus::Cia402DriveConfig d = Cia402DriveConfigOf(config_, i);
    const int b = config_.joints[i].bus;
    const transport::CanReceiveOptions options = fieldbus::Cia402Drive::ReceiveOptions(d);
    try {
      ports_.push_back(plant_ != nullptr ? plant_->MakeHostPort(b, options)
                                         : fieldbus::OpenCanPort(config_.buses[static_cast<std::size_t>(b)], options));
    } catch (const Error& e) {
      throw Error(fmt::format("arm: {}: its port: {}", Where(i), e.what()));
    }
    auto drive = std::make_unique<fieldbus::Cia402Drive>(d, *ports_.back(), setup_timebase_);
    joints_.push_back(std::make_unique<Joint>(config_.joints[i], *drive));
    drives_.push_back(std::move(drive));
    if (first_joint_of_bus_[static_cast<std::size_t>(b)] < 0) {
      first_joint_of_bus_[static_cast<std::size_t>(b)] = static_cast<int>(i);
    }
  }
  for (int b = 0; b < buses; ++b) {
    const int first = first_joint_of_bus_[static_cast<std::size_t>(b)];
    if (first < 0) throw Error(fmt::format("arm: cia402 bus {} has no joint (bus indices must run from 0)", b));
    syncs_.push_back(std::make_unique<fieldbus::canopen::SyncProducer>(*ports_[static_cast<std::size_t>(first)]));
    if (config_.host_heartbeat_period_ms > 0.0) {
      heartbeats_.push_back(std::make_unique<fieldbus::canopen::HeartbeatProducer>(
          *ports_[static_cast<std::size_t>(first)], config_.host_node_id, config_.host_heartbeat_period_ms));
    }
  }
}

Cia402JointBus::~Cia402JointBus() = default;

std::string Cia402JointBus::Where(std::size_t i) const {
  return fmt::format("joint {} '{}' (node {} on bus {})", i + 1, i < names_.size() ? names_[i] : "",
                     config_.joints[i].node_id, config_.joints[i].bus);
}

JointActuator& Cia402JointBus::joint(int i) noexcept { return *joints_[static_cast<std::size_t>(i)]; }

const fieldbus::Cia402Drive& Cia402JointBus::drive(int i) const noexcept {
  return *drives_[static_cast<std::size_t>(i)];
}

const fieldbus::canopen::HeartbeatProducer* Cia402JointBus::host_heartbeat(int b) const noexcept {
  return b >= 0 && static_cast<std::size_t>(b) < heartbeats_.size() ? heartbeats_[static_cast<std::size_t>(b)].get()
                                                                    : nullptr;
}

std::string_view Cia402JointBus::FaultName(std::uint32_t fault_code) const noexcept {
  if (fault_code == kCia402FaultSync) return "its bus refused the cycle's SYNC (bus-off or a full transmit queue)";
  if (fault_code == fieldbus::canopen::emcy::kHeartbeatError) {
    return "the drive lost the host's heartbeat (its consumer 0x1016, cia402.drive_consumer_timeout_ms): the host "
           "stopped or its loop stalled";
  }
  if (fault_code == kCia402FaultHeartbeat) {
    return "its bus refused the host's heartbeat (bus-off or a full transmit queue)";
  }
  if (fault_code < kCia402FaultHost)
    return fieldbus::canopen::DescribeEmergencyCode(static_cast<std::uint16_t>(fault_code));
  switch (static_cast<Cia402Status>(fault_code - kCia402FaultHost)) {
    case Cia402Status::kStale:
      return "the drive stopped answering (no TPDO for cia402.stale_after_ms)";
    case Cia402Status::kHeartbeatLost:
      return "the drive's heartbeat was lost (cia402.heartbeat_timeout_ms)";
    case Cia402Status::kBusOff:
      return "its bus is bus-off";
    case Cia402Status::kWriteFailed:
      return "its port refused a frame (transmit queue full or a bus error)";
    case Cia402Status::kNotEnabled:
      return "the drive left Operation Enabled (an external disable, STO, or a quick stop)";
    case Cia402Status::kFault:
      return "the drive is in Fault (no EMCY with its error code)";
    default:
      return "the drive is not in the cycle";
  }
}

void Cia402JointBus::Configure() {
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    try {
      drives_[i]->Configure();
      // The position before activation (the drive is pre-operational: no PDOs yet).
      const auto counts = static_cast<std::int32_t>(drives_[i]->sdo().Upload(0x6064, 0, 4));
      joints_[i]->SetFromDrive(counts * config_.joints[i].position_rad_per_count, 0.0);
    } catch (const Error& e) {
      throw Error(fmt::format("arm: {}: {}", Where(i), e.what()));
    }
  }
}

void Cia402JointBus::ServiceHeartbeats() noexcept {
  if (heartbeats_.empty()) return;
  const std::uint64_t now = timebase_.now_ns();
  for (auto& h : heartbeats_) (void)h->Service(now);
}

void Cia402JointBus::SetConsumer(std::size_t i, bool on) {
  if (config_.drive_consumer_timeout_ms <= 0.0) return;
  const auto ms = static_cast<std::uint16_t>(std::lround(config_.drive_consumer_timeout_ms));
  drives_[i]->sdo().Download(fieldbus::cia402::obj301::kConsumerHeartbeatTime, 1,
                             on ? fieldbus::canopen::ConsumerHeartbeatEntry(config_.host_node_id, ms) : 0u, 4);
}

void Cia402JointBus::StopDrives() noexcept {
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    (void)drives_[i]->Deactivate();
    try {
      SetConsumer(i, false);  // a cleanly stopped host leaves no drive to fault when its heartbeat stops
    } catch (...) {           // a drive that no longer answers keeps it (it faults: that is its safe state too)
    }
  }
}

void Cia402JointBus::Activate() {
  const auto undo = [this] { StopDrives(); };
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    try {
      SetConsumer(i, true);
    } catch (const Error& e) {
      undo();
      throw Error(fmt::format(
          "arm: {}: switching on its consumer of the host's heartbeat (0x1016:01 = node {} << 16 | {:g} ms) failed: "
          "{}; a drive without 0x1016 needs cia402.drive_consumer_timeout_ms: 0 (and then a dead host does not stop "
          "it)",
          Where(i), config_.host_node_id, config_.drive_consumer_timeout_ms, e.what()));
    }
    try {
      drives_[i]->Activate();
    } catch (const Error& e) {
      undo();
      throw Error(fmt::format("arm: {} did not reach Operation Enabled: {}", Where(i), e.what()));
    }
  }
  // Prime the cycle (set-up, blocking): SYNCs at the cycle period until every drive has sent a reading in
  // Operation Enabled, so the first cycle starts from measured values.
  const auto period_ns = static_cast<std::uint64_t>(std::llround(1e9 / config_.rate_hz));
  std::vector<bool> seen(drives_.size(), false);
  for (double waited_ms = 0.0; waited_ms <= config_.activate_timeout_ms; waited_ms += 1e3 / config_.rate_hz) {
    for (auto& s : syncs_) (void)s->Send();
    setup_timebase_.wait_ns(period_ns);
    bool all = true;
    for (std::size_t i = 0; i < drives_.size(); ++i) {
      fieldbus::Cia402Reading r;
      const Cia402Status st = drives_[i]->Read(r);
      if (st == Cia402Status::kOk) {
        seen[i] = true;
        joints_[i]->SetFromDrive(r.position_rad, r.velocity_rad_per_s);
      }
      if (st == Cia402Status::kFault || st == Cia402Status::kNotEnabled || st == Cia402Status::kBusOff) {
        undo();
        throw Error(fmt::format("arm: {} reported {} right after activation", Where(i), fieldbus::ToString(st)));
      }
      all = all && seen[i];
    }
    if (all) break;
  }
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    if (!seen[i]) {
      undo();
      throw Error(
          fmt::format("arm: {} sent no TPDO on SYNC within {} ms after Operation Enabled; check its PDO mapping and "
                      "transmission type (1: on every SYNC)",
                      Where(i), config_.activate_timeout_ms));
    }
  }
  // A fresh heartbeat on every bus: the loop's first cycle has drive_consumer_timeout_ms from here.
  const std::uint64_t now = timebase_.now_ns();
  for (auto& h : heartbeats_) (void)h->SendNow(now);
  for (auto& j : joints_) j->Start();
  first_cycle_ = true;
  faulted_ = false;
  active_ = true;
}

void Cia402JointBus::Deactivate() noexcept {
  active_ = false;
  for (auto& j : joints_) j->Stop();
  StopDrives();
}

void Cia402JointBus::Fault() noexcept {
  faulted_ = true;
  for (auto& d : drives_) d->RequestQuickStop();
}

bool Cia402JointBus::InGrace(std::uint64_t now_ns) noexcept {
  if (first_cycle_) {
    // Between Activate() and the loop's first cycle the process may have waited (its peer, the start-up check):
    // the activation-time readings count as current until the loop's first SYNC has had time to answer.
    first_cycle_ = false;
    grace_end_ns_ = now_ns + static_cast<std::uint64_t>(config_.stale_after_ms * 1e6);
  }
  return now_ns < grace_end_ns_;
}

void Cia402JointBus::StartCycle() noexcept {
  if (!active_) return;
  const std::uint64_t now = timebase_.now_ns();
  const bool in_grace = InGrace(now);
  bool any = false;
  for (auto& j : joints_) {
    j->TakeIn(in_grace);  // the TPDOs sampled at the previous SYNC
    any = any || j->fault();
  }
  // The cycle's one SYNC per bus, after the TPDOs of the previous one were drained and long after the previous
  // cycle's RPDOs: every drive applies those torques on it, together, and samples its next TPDOs.
  for (std::size_t b = 0; b < syncs_.size(); ++b) {
    if (syncs_[b]->Send() != transport::CanWriteStatus::kOk) {
      joints_[static_cast<std::size_t>(first_joint_of_bus_[b])]->LatchBus(kCia402FaultSync);
      any = true;
    }
  }
  // The host's heartbeat, when due: it stops when this loop stops, and the drives' consumers fire.
  for (std::size_t b = 0; b < heartbeats_.size(); ++b) {
    if (heartbeats_[b]->Service(now) != transport::CanWriteStatus::kOk) {
      joints_[static_cast<std::size_t>(first_joint_of_bus_[b])]->LatchBus(kCia402FaultHeartbeat);
      any = true;
    }
  }
  if (any && !faulted_) Fault();
}

void Cia402JointBus::Exchange(double period_s) noexcept {
  if (active_) {
    if (faulted_) {
      for (auto& j : joints_) j->WriteTorque(0.0);
    }
    bool any = false;
    for (auto& j : joints_) {
      j->Send();  // the RPDO, applied at the next SYNC; quick stop once faulted
      any = any || j->fault();
    }
    if (any && !faulted_) Fault();
  }
  if (plant_ != nullptr) plant_->Advance(period_s);
}

}  // namespace teleop::device::arm
