#pragma once

// The CiA 402 (IEC 61800-7-201) power drive state machine: statusword 0x6041 decoding, controlword 0x6040
// commands, and the drive-side transitions 0..16 (used by the simulated drive). docs/cia402.md has the table.

#include <cstdint>

namespace teleop::fieldbus::cia402 {

/// The states of CiA 402 (figure "State machine"), as decoded from the statusword.
enum class DriveState : std::uint8_t {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
  kUnknown,  ///< A statusword that matches no state (a broken drive or a misread PDO).
};
const char* ToString(DriveState state) noexcept;

/// Statusword bits (CiA 402 Table "Statusword").
namespace sw {
inline constexpr std::uint16_t kReadyToSwitchOn = 1u << 0;
inline constexpr std::uint16_t kSwitchedOn = 1u << 1;
inline constexpr std::uint16_t kOperationEnabled = 1u << 2;
inline constexpr std::uint16_t kFault = 1u << 3;
inline constexpr std::uint16_t kVoltageEnabled = 1u << 4;
inline constexpr std::uint16_t kQuickStop = 1u << 5;  ///< 0 = quick stop active.
inline constexpr std::uint16_t kSwitchOnDisabled = 1u << 6;
inline constexpr std::uint16_t kWarning = 1u << 7;
inline constexpr std::uint16_t kRemote = 1u << 9;
inline constexpr std::uint16_t kTargetReached = 1u << 10;
inline constexpr std::uint16_t kInternalLimitActive = 1u << 11;
inline constexpr std::uint16_t kFollowsCommand = 1u << 12;  ///< CSP/CSV/CST: drive follows the command value.
}  // namespace sw

/// Controlword bits and the commands of CiA 402 Table "Device control commands".
namespace cw {
inline constexpr std::uint16_t kSwitchOn = 1u << 0;
inline constexpr std::uint16_t kEnableVoltage = 1u << 1;
inline constexpr std::uint16_t kQuickStop = 1u << 2;  ///< 0 = quick stop.
inline constexpr std::uint16_t kEnableOperation = 1u << 3;
inline constexpr std::uint16_t kFaultReset = 1u << 7;  ///< Acts on its rising edge.
inline constexpr std::uint16_t kHalt = 1u << 8;

inline constexpr std::uint16_t kCmdShutdown = 0x0006;         ///< Transitions 2, 6, 8.
inline constexpr std::uint16_t kCmdSwitchOn = 0x0007;         ///< Transition 3 (and 5: disable operation).
inline constexpr std::uint16_t kCmdEnableOperation = 0x000F;  ///< Transitions 4, 16 (3 + 4 from Ready).
inline constexpr std::uint16_t kCmdDisableVoltage = 0x0000;   ///< Transitions 7, 9, 10, 12.
inline constexpr std::uint16_t kCmdQuickStop = 0x0002;        ///< Transitions 7, 10, 11.
inline constexpr std::uint16_t kCmdFaultReset = 0x0080;       ///< Transition 15 (rising edge of bit 7).
}  // namespace cw

/// Decodes the state bits (0, 1, 2, 3, 5, 6) of a statusword.
DriveState DecodeStatusword(std::uint16_t statusword) noexcept;
/// The state bits of `state` (what a drive reports); other bits 0. kUnknown gives 0.
std::uint16_t StatuswordBits(DriveState state) noexcept;

/// The controlword a master sends in `state` to move one step toward Operation Enabled (Fault: fault reset,
/// which needs a 0 in bit 7 first: `previous_controlword` tells whether the edge is there; when it is not, the
/// command is 0 so the next one rises).
std::uint16_t ControlwordTowardOperationEnabled(DriveState state, std::uint16_t previous_controlword) noexcept;

/// Objects of CiA 402 used here (CiA 402-2 object dictionary).
namespace obj {
inline constexpr std::uint16_t kErrorCode = 0x603F;                ///< UNSIGNED16, last error.
inline constexpr std::uint16_t kControlword = 0x6040;              ///< UNSIGNED16.
inline constexpr std::uint16_t kStatusword = 0x6041;               ///< UNSIGNED16.
inline constexpr std::uint16_t kQuickStopOptionCode = 0x605A;      ///< INTEGER16.
inline constexpr std::uint16_t kHaltOptionCode = 0x605D;           ///< INTEGER16, 1..4.
inline constexpr std::uint16_t kFaultReactionOptionCode = 0x605E;  ///< INTEGER16.
inline constexpr std::uint16_t kModesOfOperation = 0x6060;         ///< INTEGER8.
inline constexpr std::uint16_t kModesOfOperationDisplay = 0x6061;  ///< INTEGER8.
inline constexpr std::uint16_t kPositionActual = 0x6064;           ///< INTEGER32, position units (counts).
inline constexpr std::uint16_t kVelocityActual = 0x606C;           ///< INTEGER32, velocity units.
inline constexpr std::uint16_t kTargetPosition = 0x607A;           ///< INTEGER32, position units (CSP).
inline constexpr std::uint16_t kProfileDeceleration = 0x6084;      ///< UNSIGNED32, velocity units per s.
inline constexpr std::uint16_t kQuickStopDeceleration = 0x6085;    ///< UNSIGNED32, velocity units per s.
inline constexpr std::uint16_t kTargetVelocity = 0x60FF;           ///< INTEGER32, velocity units (CSV).
inline constexpr std::uint16_t kTargetTorque = 0x6071;             ///< INTEGER16, per mille of rated torque.
inline constexpr std::uint16_t kMaxTorque = 0x6072;                ///< UNSIGNED16, per mille of rated torque.
inline constexpr std::uint16_t kRatedTorque = 0x6076;              ///< UNSIGNED32, mN·m.
inline constexpr std::uint16_t kTorqueActual = 0x6077;             ///< INTEGER16, per mille of rated torque.
inline constexpr std::uint16_t kSupportedDriveModes = 0x6502;      ///< UNSIGNED32, bit 9 = cyclic sync torque.
}  // namespace obj

/// Communication objects of CiA 301 used here.
namespace obj301 {
inline constexpr std::uint16_t kDeviceType = 0x1000;     ///< UNSIGNED32; 0x0192 (402) in bits 0..15.
inline constexpr std::uint16_t kErrorRegister = 0x1001;  ///< UNSIGNED8.
inline constexpr std::uint16_t kErrorHistory =
    0x1003;                                          ///< sub 0 count (write 0: clear), sub n UNSIGNED32, newest at 1.
inline constexpr std::uint16_t kCobIdSync = 0x1005;  ///< UNSIGNED32.
inline constexpr std::uint16_t kCommunicationCyclePeriod = 0x1006;  ///< UNSIGNED32, µs.
inline constexpr std::uint16_t kDeviceName = 0x1008;                ///< VISIBLE_STRING (segmented when > 4 bytes).
inline constexpr std::uint16_t kHardwareVersion = 0x1009;           ///< VISIBLE_STRING.
inline constexpr std::uint16_t kSoftwareVersion = 0x100A;           ///< VISIBLE_STRING.
inline constexpr std::uint16_t kCobIdEmcy = 0x1014;                 ///< UNSIGNED32.
inline constexpr std::uint16_t kConsumerHeartbeatTime = 0x1016;     ///< sub n: UNSIGNED32 node << 16 | ms.
inline constexpr std::uint16_t kProducerHeartbeatTime = 0x1017;     ///< UNSIGNED16, ms.
inline constexpr std::uint16_t kIdentity = 0x1018;                  ///< sub 1 vendor, 2 product, 3 revision, 4 serial.
inline constexpr std::uint16_t kRpdoCommunication = 0x1400;         ///< + n - 1; sub 1 COB-ID, sub 2 type.
inline constexpr std::uint16_t kRpdoMapping = 0x1600;               ///< + n - 1; sub 0 count, sub 1..8 entries.
inline constexpr std::uint16_t kTpdoCommunication = 0x1800;         ///< + n - 1; sub 1 COB-ID, sub 2 type.
inline constexpr std::uint16_t kTpdoMapping = 0x1A00;               ///< + n - 1.
}  // namespace obj301

/// Modes of operation (0x6060). 0x6502 (supported drive modes) has bit m - 1 set for each mode m supported.
inline constexpr std::int8_t kModeCyclicSynchronousPosition = 8;
inline constexpr std::int8_t kModeCyclicSynchronousVelocity = 9;
inline constexpr std::int8_t kModeCyclicSynchronousTorque = 10;
/// The 0x6502 bit of mode `mode` (1..10; 0 for anything else).
constexpr std::uint32_t SupportedModeBit(std::int8_t mode) noexcept {
  return mode >= 1 && mode <= 10 ? 1u << (mode - 1) : 0u;
}
/// Device type 0x1000 bits 0..15 of a CiA 402 drive.
inline constexpr std::uint32_t kDeviceProfile402 = 0x0192;

/// The drive side of the state machine (the simulated drive; a test oracle). Transitions are numbered as in
/// CiA 402. No allocation, no exceptions.
class DriveStateMachine {
 public:
  DriveState state() const noexcept { return state_; }
  /// Transitions 0 + 1: after initialisation the drive waits in Switch On Disabled.
  void FinishInitialisation() noexcept;
  /// Applies a controlword; returns the transition number taken (0 when none). `quick_stop_to_disabled`: 0x605A
  /// makes quick stop end in Switch On Disabled (transition 12 at once; options 0..4) rather than stay in Quick
  /// Stop Active (5..8, left with transition 16 or 12).
  int Apply(std::uint16_t controlword, bool quick_stop_to_disabled) noexcept;
  /// Transition 13: a fault from any state (Fault Reaction Active), then 14 with FaultReactionDone().
  void Fault() noexcept;
  void FaultReactionDone() noexcept;
  /// Bits 0..6 of the statusword, with voltage enabled (bit 4) in the powered states.
  std::uint16_t Statusword() const noexcept;

 private:
  DriveState state_ = DriveState::kNotReadyToSwitchOn;
  std::uint16_t previous_controlword_ = 0;
};

}  // namespace teleop::fieldbus::cia402
