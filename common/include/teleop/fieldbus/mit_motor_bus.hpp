#pragma once

// The host side of MIT-mode joint motors on one CAN bus (docs/mit-motors.md): one bus exchange per cycle (every
// motor's replies to the last exchange in, then this cycle's commands out), missing replies counted per motor and a
// fault after a configured number in a row, each motor's status code kept with its name. Set-up calls (register
// read/write with a timeout) block and are made before the cycle starts; the cycle calls never allocate, lock or throw.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/proto/can/mit_motor.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

struct MitMotorConfig {
  std::string name = "motor";             ///< For messages ("joint 3", "shoulder").
  std::uint32_t esc_id = 0x01;            ///< The id commands go to (register 8).
  std::uint32_t master_id = 0x11;         ///< The id it answers on (register 7); unique on the bus.
  proto::can::mit::MotorRanges ranges{};  ///< Must equal the motor's registers 21..23 (checked by VerifyRanges).
};

/// What one motor's last exchanges showed.
struct MitMotorState {
  proto::can::mit::Feedback feedback{};  ///< The newest feedback (valid once `answered`).
  bool answered = false;                 ///< A feedback has arrived since Activate/the bus was made.
  int missing_in_a_row = 0;              ///< Exchanges whose command got no feedback before the next exchange.
  std::uint64_t missing = 0;
  std::uint64_t clamped = 0;  ///< Commands with a field clamped into its range.
  std::uint64_t refused = 0;  ///< Commands not sent: a non-finite field.
  std::uint64_t write_failures = 0;
};

struct MitBusCounters {
  std::uint64_t exchanges = 0;
  std::uint64_t frames_unexpected = 0;  ///< Frames on the bus that are no motor's feedback (wrong id, length, nibble).
};

class MitMotorBus {
 public:
  /// `port` must outlive the bus and should receive ReceiveOptions(motors). Throws teleop::Error on duplicate or
  /// out-of-range ids, or invalid ranges.
  /// `timebase` is the set-up calls' clock and wait (a test passes one that steps the simulated motors).
  MitMotorBus(transport::CanPort& port, std::vector<MitMotorConfig> motors, bool fd = false,
              Timebase timebase = Timebase::Steady());

  /// The master ids of `motors` (classic and FD), no error frames.
  static transport::CanReceiveOptions ReceiveOptions(std::span<const MitMotorConfig> motors);

  [[nodiscard]] std::size_t size() const noexcept { return motors_.size(); }
  [[nodiscard]] const MitMotorConfig& config(std::size_t i) const { return motors_.at(i); }

  // ---- set-up (blocking; before the cycle) ----
  /// Reads a register (nullopt when the motor does not answer within `timeout_s`). Frames that arrive meanwhile
  /// are dropped.
  std::optional<std::uint32_t> ReadRegister(std::size_t motor, std::uint8_t reg, double timeout_s);
  /// Writes a register (the motor must be disabled) and checks the answer echoes the value.
  bool WriteRegister(std::size_t motor, std::uint8_t reg, std::uint32_t value, double timeout_s);
  /// Reads P_MAX, V_MAX, T_MAX of the motor and throws teleop::Error naming the motor and the first register whose
  /// value differs from the configured range by more than 1e-4 (or that does not answer).
  void VerifyRanges(std::size_t motor, double timeout_s);
  /// Sends a special frame to every motor (enable, disable) or one, and waits up to `timeout_s` for their feedback;
  /// returns the motors that did not answer. An answer to enable/disable counts once it shows the new state (a late
  /// feedback of the last command is not taken for it), or at the deadline.
  std::vector<std::size_t> SendSpecialAndWait(proto::can::mit::Special what, double timeout_s,
                                              std::optional<std::size_t> only = std::nullopt);

  // ---- the cycle ----
  /// The command the next Exchange sends to `motor` (kept until replaced).
  void SetCommand(std::size_t motor, const proto::can::mit::Command& command) noexcept;
  /// One bus exchange: reads every pending frame (the replies to the last exchange), counts a motor that did not
  /// answer, then sends each motor its command. Returns false when a write failed.
  bool Exchange() noexcept;
  /// Reads pending frames only (no command out): the tools' listen loops.
  void Drain() noexcept;
  /// Every motor has answered the command of the last Exchange (a cycle that waits for the replies stops here).
  [[nodiscard]] bool AllAnswered() const noexcept;
  /// Sends a special frame (disable on a fault, in the safe state) to one motor, outside the command stream.
  void SendSpecial(std::size_t motor, proto::can::mit::Special what) noexcept;

  [[nodiscard]] const MitMotorState& state(std::size_t motor) const noexcept { return state_[motor]; }
  [[nodiscard]] const MitBusCounters& counters() const noexcept { return counters_; }

 private:
  void Dispatch(const proto::can::CanFrame& frame) noexcept;
  bool Write(const proto::can::CanFrame& frame) noexcept;

  transport::CanPort& port_;
  std::vector<MitMotorConfig> motors_;
  std::vector<MitMotorState> state_;
  std::vector<proto::can::mit::Command> commands_;
  std::vector<char> awaiting_;  ///< A command was sent and no feedback has come since.
  bool fd_;
  Timebase timebase_;
  MitBusCounters counters_;
  /// The parameter answer a set-up call waits for (Dispatch fills it), or none.
  struct PendingParameter {
    bool waiting = false;
    std::size_t motor = 0;
    std::uint8_t reg = 0;
    std::optional<proto::can::mit::Parameter> answer;
  } pending_;
};

}  // namespace teleop::fieldbus
