#pragma once

// The "MIT mode" protocol of quasi-direct-drive joint motors on CAN (the packing of the MIT Cheetah motor
// controller, spoken by Damiao DM-J motors -- the joints of OpenArm -- and with the same field packing by CubeMars AK
// and MyActuator motors). Pure codec: values <-> frames, no I/O, no exceptions, no allocation. docs/mit-motors.md
// draws every frame with its bytes; tests/can/can_mit_motor_test.cpp holds the golden bytes.
//
// Frames (all 11-bit identifiers, 8 data bytes):
//   command   host -> motor, id = the motor's CAN id (ESC_ID):
//             D0..D1 position 16 bit | D2, D3[7:4] velocity 12 bit | D3[3:0], D4 Kp 12 bit | D5, D6[7:4] Kd 12 bit |
//             D6[3:0], D7 feed-forward torque 12 bit; big-endian bit order, each field mapped linearly over its range.
//   feedback  motor -> host, id = the motor's master id (MST_ID):
//             D0 = (ESC_ID & 0x0F) | error << 4 | D1..D2 position 16 | D3, D4[7:4] velocity 12 |
//             D4[3:0], D5 torque 12 | D6 MOS temperature (deg C) | D7 rotor temperature (deg C).
//   special   host -> motor, id = ESC_ID: FF FF FF FF FF FF FF xx with xx = FC enable, FD disable, FE set zero,
//             FB clear error.
//   parameter host -> motor on id 0x7FF: [ESC_ID lo, ESC_ID hi, 0x33 read | 0x55 write | 0xAA save, register,
//             value (4 bytes, little-endian: IEEE-754 float or uint32 by register)]; the motor answers on MST_ID
//             with the same layout (0x33 or 0x55 and the register's value).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "teleop/proto/can/can_frame.hpp"

namespace teleop::proto::can::mit {

/// Field widths of the command and feedback frames.
inline constexpr int kPositionBits = 16;
inline constexpr int kVelocityBits = 12;
inline constexpr int kGainBits = 12;
inline constexpr int kTorqueBits = 12;
/// The identifier parameter frames are sent on.
inline constexpr std::uint32_t kParameterId = 0x7FF;

/// The ranges a motor model maps its fixed-point fields over: position in [-P_MAX, P_MAX], velocity in
/// [-V_MAX, V_MAX], torque in [-T_MAX, T_MAX], Kp in [0, kp_max], Kd in [0, kd_max]. The motor itself holds
/// P_MAX/V_MAX/T_MAX (registers 21..23): host and motor must agree, or every value is scaled wrong
/// (`teleop-motor info` compares them).
struct MotorRanges {
  double position_max_rad = 12.5;
  double velocity_max_rad_per_s = 30.0;
  double torque_max_Nm = 10.0;
  double kp_max_Nm_per_rad = 500.0;
  double kd_max_Nm_s_per_rad = 5.0;
};

/// One MIT-mode command: the motor applies τ = Kp·(p − θ) + Kd·(v − θ̇) + τ_ff in its own loop. Kp = Kd = 0 makes it a
/// torque command.
struct Command {
  double position_rad = 0;
  double velocity_rad_per_s = 0;
  double kp_Nm_per_rad = 0;
  double kd_Nm_s_per_rad = 0;
  double torque_Nm = 0;
};

/// Which fields of a command were clamped into their range (bits of EncodeResult::clamped).
enum CommandField : std::uint8_t {
  kFieldPosition = 0x01,
  kFieldVelocity = 0x02,
  kFieldKp = 0x04,
  kFieldKd = 0x08,
  kFieldTorque = 0x10,
};

struct EncodeResult {
  bool ok = false;           ///< False: a field was not finite (or the ranges are invalid); the frame is untouched.
  std::uint8_t clamped = 0;  ///< CommandField bits of the fields clamped into range (the caller counts them).
  bool nudged = false;       ///< The packed bytes spelled a special frame; the torque was moved one step to zero.
};

/// Encodes `command` for the motor `esc_id` (1..0x7FE) into `out` (classic 8-byte frame, or an FD frame with the same
/// 8 bytes when `fd`). Fields outside their range are clamped and flagged; a non-finite field refuses the frame.
/// The packing truncates toward the range's lower end as the vendors' float_to_uint does.
[[nodiscard]] EncodeResult EncodeCommand(const Command& command, const MotorRanges& ranges, std::uint32_t esc_id,
                                         CanFrame& out, bool fd = false) noexcept;

/// Decodes a command frame as the motor does (the simulated motor, a bus monitor). False for a frame that is not 8
/// data bytes or spells a special frame.
[[nodiscard]] bool DecodeCommand(const CanFrame& frame, const MotorRanges& ranges, Command& out) noexcept;

/// The motor's state and error code, the high nibble of a feedback frame's D0.
enum class MotorStatus : std::uint8_t {
  kDisabled = 0x0,
  kEnabled = 0x1,
  kOverVoltage = 0x8,
  kUnderVoltage = 0x9,
  kOverCurrent = 0xA,
  kMosOverTemperature = 0xB,
  kCoilOverTemperature = 0xC,
  kCommunicationLost = 0xD,  ///< The motor's own CAN timeout (register 9) ran out: it disabled itself.
  kOverload = 0xE,
};

/// True for the codes that are faults (8..E and any code the protocol does not name); false for disabled/enabled.
bool IsFault(std::uint8_t status_code) noexcept;
/// "disabled", "enabled", "over-voltage", ..., or "unknown error code" for codes the protocol does not name.
std::string_view StatusName(std::uint8_t status_code) noexcept;

struct Feedback {
  std::uint8_t esc_id_low = 0;  ///< The low nibble of the motor's ESC_ID, as D0 carries it.
  std::uint8_t status = 0;      ///< MotorStatus code (0..15).
  double position_rad = 0;
  double velocity_rad_per_s = 0;
  double torque_Nm = 0;
  double mos_temperature_C = 0;
  double rotor_temperature_C = 0;
};

enum class DecodeStatus : std::uint8_t {
  kOk,
  kWrongId,      ///< Not the configured master id.
  kWrongLength,  ///< Not 8 data bytes (or a remote/error frame).
  kWrongMotor,   ///< D0's low nibble is not this motor's ESC_ID.
};

/// Decodes a feedback frame of motor `esc_id` sent on `master_id`. `out` is written only on kOk.
/// A parameter answer arrives on the same master id and cannot be told from feedback by its bytes alone (feedback
/// with D0..D2 = ESC_ID lo, hi, 0x33 is a position near -P_MAX): only a host with a parameter request outstanding
/// reads a frame as an answer (DecodeParameter), as the vendors' own hosts do.
[[nodiscard]] DecodeStatus DecodeFeedback(const CanFrame& frame, const MotorRanges& ranges, std::uint32_t master_id,
                                          std::uint32_t esc_id, Feedback& out) noexcept;

/// The special frames (host -> motor on ESC_ID).
enum class Special : std::uint8_t { kClearError = 0xFB, kEnable = 0xFC, kDisable = 0xFD, kSetZero = 0xFE };
void EncodeSpecial(Special what, std::uint32_t esc_id, CanFrame& out, bool fd = false) noexcept;
/// The special frame a frame spells, if it is one (8 bytes, seven 0xFF and one of FB..FE).
std::optional<Special> DecodeSpecial(const CanFrame& frame) noexcept;

/// The registers a bring-up reads or writes (Damiao register numbers).
enum class Register : std::uint8_t {
  kMasterId = 7,      ///< MST_ID (uint32): the id feedback is sent on.
  kEscId = 8,         ///< ESC_ID (uint32): the motor's own id.
  kTimeout = 9,       ///< TIMEOUT (uint32, kTimeoutCount_s per count): no command for this long disables the motor.
  kControlMode = 10,  ///< CTRL_MODE (uint32): 1 MIT, 2 position-velocity, 3 velocity, 4 force-position.
  kFirmware = 14,     ///< sw_ver (uint32).
  kPositionMax = 21,  ///< PMAX (float, rad).
  kVelocityMax = 22,  ///< VMAX (float, rad/s).
  kTorqueMax = 23,    ///< TMAX (float, N·m).
};
/// Seconds per count of the TIMEOUT register (Damiao: 50 µs per count).
inline constexpr double kTimeoutCount_s = 50e-6;
inline constexpr std::uint32_t kControlModeMit = 1;

/// True for the registers whose value is a float (PMAX, VMAX, TMAX); the others are uint32.
bool IsFloatRegister(std::uint8_t reg) noexcept;

enum class ParameterOp : std::uint8_t { kRead = 0x33, kWrite = 0x55, kSave = 0xAA };

/// A parameter request or answer. `value` holds the register's 4 bytes as a uint32 (a float register's IEEE-754
/// bits); FloatValue/FromFloat convert.
struct Parameter {
  std::uint16_t esc_id = 0;
  ParameterOp op = ParameterOp::kRead;
  std::uint8_t reg = 0;
  std::uint32_t value = 0;
  [[nodiscard]] float FloatValue() const noexcept;
  static std::uint32_t FromFloat(float v) noexcept;
};

/// Host -> motor on 0x7FF: read (value ignored, sent as 0), write, or save (reg 1, value 0: the vendor's "store
/// parameters to flash"; only while disabled).
void EncodeParameter(const Parameter& request, CanFrame& out) noexcept;
/// A parameter frame (request on 0x7FF or answer on the master id): 8 bytes, op 0x33/0x55/0xAA.
[[nodiscard]] std::optional<Parameter> DecodeParameter(const CanFrame& frame) noexcept;

/// Fixed-point mapping used by every field: x in [lo, hi] -> 0..2^bits-1 (truncating), and back.
std::uint32_t ToFixed(double x, double lo, double hi, int bits) noexcept;
double FromFixed(std::uint32_t v, double lo, double hi, int bits) noexcept;

/// The bus time of one MIT exchange per motor and cycle (a command and its feedback, both 11-bit, 8 bytes, worst-case
/// stuffing) and the load of a rig of `motors` motors at `rate_hz` on one bus.
struct MitBusLoad {
  double exchange_time_s = 0;  ///< Command + feedback of one motor.
  double load = 0;             ///< Fraction of bus time: motors · exchange_time · rate.
  int max_motors = 0;          ///< Motors that fit within the `max_load` given.
};
MitBusLoad ComputeMitBusLoad(int motors, double rate_hz, bool fd, bool brs, double nominal_bit_per_s,
                             double data_bit_per_s, double max_load) noexcept;

}  // namespace teleop::proto::can::mit
