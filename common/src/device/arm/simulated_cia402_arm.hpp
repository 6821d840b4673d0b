#pragma once

// The simulated arm on simulated CiA 402 drives (docs/arms.md, "CiA 402 joints"): the simulated arm's rigid-body
// dynamics (simulated_arm.hpp) driven through one fieldbus::SimulatedCia402Drive per joint (external shaft: the
// drive runs its state machine, its loops and its torque lag, the arm moves the shaft), on one in-process emulated
// classic CAN bus per bus index (transport::EmulatedCanBus on this plant's clock), so the Cia402JointBus under test
// speaks the bytes real drives speak: NMT, SDO set-up, SYNC, RPDOs and TPDOs, heartbeats and EMCY cross the
// emulated buses at their bit rate.
//
// Advance(period_s), once per cycle after the host's RPDOs: the clock runs over the period in steps of at most
// 50 µs (each bus delivers what has finished, each drive serves what reached it and integrates its loops); at each
// of the arm's `substeps` the drives' applied torques drive the arm, τ_joint = sign·gear·τ_drive, and the shafts
// follow the arm, θ = sign·gear·(q − offset). Set-up waits (the SDO set-up, the state machine, the priming SYNCs)
// advance the buses and the drives alone: the arm holds still meanwhile (as if braked).

#include <cstdint>
#include <memory>
#include <vector>

#include "cia402_joint_bus.hpp"
#include "simulated_arm.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::device::arm {

class SimulatedCia402Arm final : public Cia402Plant {
 public:
  /// `arm`: the dynamics (stepped once per plant substep). Throws teleop::Error when the joint counts differ.
  SimulatedCia402Arm(std::unique_ptr<SimulatedArm> arm, const Cia402JointBusConfig& config, int substeps);
  ~SimulatedCia402Arm() override;

  void Advance(double period_s) noexcept override;
  fieldbus::Timebase timebase() override;
  std::unique_ptr<transport::CanPort> MakeHostPort(int bus, const transport::CanReceiveOptions& options) override;

  // Test access.
  SimulatedArm& arm() noexcept { return *arm_; }
  fieldbus::SimulatedCia402Drive& drive(int i) noexcept { return *drives_[static_cast<std::size_t>(i)]; }
  transport::EmulatedCanBus& bus(int b) noexcept { return *buses_[static_cast<std::size_t>(b)]; }
  std::uint64_t now_ns() const noexcept { return now_ns_; }

 private:
  void StepBuses(std::uint64_t until_ns) noexcept;
  void FollowArm() noexcept;

  std::uint64_t now_ns_ = 0;
  std::vector<std::unique_ptr<transport::EmulatedCanBus>> buses_;
  std::unique_ptr<SimulatedArm> arm_;
  Cia402JointBusConfig config_;
  int substeps_;
  std::vector<std::unique_ptr<transport::CanPort>> drive_ports_;
  std::vector<std::unique_ptr<fieldbus::SimulatedCia402Drive>> drives_;
};

}  // namespace teleop::device::arm
