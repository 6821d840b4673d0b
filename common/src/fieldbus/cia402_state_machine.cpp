#include "teleop/fieldbus/cia402_state_machine.hpp"

namespace teleop::fieldbus::cia402 {

const char* ToString(DriveState state) noexcept {
  switch (state) {
    case DriveState::kNotReadyToSwitchOn:
      return "Not Ready To Switch On";
    case DriveState::kSwitchOnDisabled:
      return "Switch On Disabled";
    case DriveState::kReadyToSwitchOn:
      return "Ready To Switch On";
    case DriveState::kSwitchedOn:
      return "Switched On";
    case DriveState::kOperationEnabled:
      return "Operation Enabled";
    case DriveState::kQuickStopActive:
      return "Quick Stop Active";
    case DriveState::kFaultReactionActive:
      return "Fault Reaction Active";
    case DriveState::kFault:
      return "Fault";
    case DriveState::kUnknown:
      return "unknown";
  }
  return "invalid";
}

DriveState DecodeStatusword(std::uint16_t s) noexcept {
  // CiA 402 Table "State coding": x = don't care; bits 6 5 3 2 1 0.
  if ((s & 0x4F) == 0x00) return DriveState::kNotReadyToSwitchOn;
  if ((s & 0x4F) == 0x40) return DriveState::kSwitchOnDisabled;
  if ((s & 0x6F) == 0x21) return DriveState::kReadyToSwitchOn;
  if ((s & 0x6F) == 0x23) return DriveState::kSwitchedOn;
  if ((s & 0x6F) == 0x27) return DriveState::kOperationEnabled;
  if ((s & 0x6F) == 0x07) return DriveState::kQuickStopActive;
  if ((s & 0x4F) == 0x0F) return DriveState::kFaultReactionActive;
  if ((s & 0x4F) == 0x08) return DriveState::kFault;
  return DriveState::kUnknown;
}

std::uint16_t StatuswordBits(DriveState state) noexcept {
  switch (state) {
    case DriveState::kNotReadyToSwitchOn:
      return 0x0000;
    case DriveState::kSwitchOnDisabled:
      return 0x0040;
    case DriveState::kReadyToSwitchOn:
      return 0x0021;
    case DriveState::kSwitchedOn:
      return 0x0023;
    case DriveState::kOperationEnabled:
      return 0x0027;
    case DriveState::kQuickStopActive:
      return 0x0007;
    case DriveState::kFaultReactionActive:
      return 0x000F;
    case DriveState::kFault:
      return 0x0008;
    case DriveState::kUnknown:
      return 0x0000;
  }
  return 0;
}

std::uint16_t ControlwordTowardOperationEnabled(DriveState state, std::uint16_t previous_controlword) noexcept {
  switch (state) {
    case DriveState::kSwitchOnDisabled:
      return cw::kCmdShutdown;  // 2
    case DriveState::kReadyToSwitchOn:
      return cw::kCmdSwitchOn;  // 3
    case DriveState::kSwitchedOn:
    case DriveState::kOperationEnabled:
    case DriveState::kQuickStopActive:
      return cw::kCmdEnableOperation;  // 4, 16
    case DriveState::kFault:
      // 15 acts on the rising edge of bit 7: send it low first when it was high.
      return (previous_controlword & cw::kFaultReset) != 0 ? std::uint16_t{0} : cw::kCmdFaultReset;
    case DriveState::kNotReadyToSwitchOn:
    case DriveState::kFaultReactionActive:
    case DriveState::kUnknown:
      return cw::kCmdDisableVoltage;  // wait: the drive moves on by itself
  }
  return cw::kCmdDisableVoltage;
}

void DriveStateMachine::FinishInitialisation() noexcept {
  if (state_ == DriveState::kNotReadyToSwitchOn) state_ = DriveState::kSwitchOnDisabled;
}

int DriveStateMachine::Apply(std::uint16_t c, bool quick_stop_to_disabled) noexcept {
  const bool rising_reset = (c & cw::kFaultReset) != 0 && (previous_controlword_ & cw::kFaultReset) == 0;
  previous_controlword_ = c;
  // Command decoding (CiA 402 Table "Command coding"); fault reset is bit 7 alone.
  const bool disable_voltage = (c & cw::kEnableVoltage) == 0;
  const bool quick_stop = !disable_voltage && (c & cw::kQuickStop) == 0;
  const bool shutdown = (c & 0x87) == 0x06;
  const bool switch_on = (c & 0x8F) == 0x07;  // also "disable operation"
  const bool enable_operation = (c & 0x8F) == 0x0F;
  const auto go = [this](DriveState next, int transition) {
    state_ = next;
    return transition;
  };
  switch (state_) {
    case DriveState::kSwitchOnDisabled:
      if (shutdown) return go(DriveState::kReadyToSwitchOn, 2);
      return 0;
    case DriveState::kReadyToSwitchOn:
      if (switch_on) return go(DriveState::kSwitchedOn, 3);
      if (enable_operation) return go(DriveState::kOperationEnabled, 4);  // 3 + 4 in one command, as drives accept
      if (disable_voltage || quick_stop) return go(DriveState::kSwitchOnDisabled, 7);
      return 0;
    case DriveState::kSwitchedOn:
      if (enable_operation) return go(DriveState::kOperationEnabled, 4);
      if (shutdown) return go(DriveState::kReadyToSwitchOn, 6);
      if (disable_voltage || quick_stop) return go(DriveState::kSwitchOnDisabled, 10);
      return 0;
    case DriveState::kOperationEnabled:
      if (switch_on) return go(DriveState::kSwitchedOn, 5);
      if (shutdown) return go(DriveState::kReadyToSwitchOn, 8);
      if (disable_voltage) return go(DriveState::kSwitchOnDisabled, 9);
      if (quick_stop) {
        return go(quick_stop_to_disabled ? DriveState::kSwitchOnDisabled : DriveState::kQuickStopActive, 11);
      }
      return 0;
    case DriveState::kQuickStopActive:
      if (disable_voltage) return go(DriveState::kSwitchOnDisabled, 12);
      if (enable_operation) return go(DriveState::kOperationEnabled, 16);
      return 0;
    case DriveState::kFault:
      if (rising_reset) return go(DriveState::kSwitchOnDisabled, 15);
      return 0;
    case DriveState::kNotReadyToSwitchOn:
    case DriveState::kFaultReactionActive:
    case DriveState::kUnknown:
      return 0;
  }
  return 0;
}

void DriveStateMachine::Fault() noexcept {
  if (state_ != DriveState::kFault) state_ = DriveState::kFaultReactionActive;  // 13
}

void DriveStateMachine::FaultReactionDone() noexcept {
  if (state_ == DriveState::kFaultReactionActive) state_ = DriveState::kFault;  // 14
}

std::uint16_t DriveStateMachine::Statusword() const noexcept {
  std::uint16_t s = StatuswordBits(state_);
  if (state_ == DriveState::kReadyToSwitchOn || state_ == DriveState::kSwitchedOn ||
      state_ == DriveState::kOperationEnabled || state_ == DriveState::kQuickStopActive) {
    s |= sw::kVoltageEnabled;
  }
  return s;
}

}  // namespace teleop::fieldbus::cia402
