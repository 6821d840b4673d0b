#pragma once

// Run-time commands from the command side (TeleopNode::Request*, any thread) to the cycle: posted through a
// wait-free ring, drained once per cycle into one Changes value (docs/architecture.md, "The cycle"). Private to the
// node.

#include <array>
#include <atomic>
#include <cstdint>

#include "coupling/changes.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/runtime/spsc_ring.hpp"

namespace teleop::node {

/// A command's outcome (and, when accepted, its change). The cycle applies the change and logs the event (the event
/// ring has one producer, the cycle).
struct PendingCommand {
  enum class Change : std::uint8_t { kNone, kStiffness, kGains, kPlane, kPassivity };
  Event::Kind kind = Event::Kind::kCommandRefused;
  double value = 0.0;
  std::uint16_t detail = 0;
  Change change = Change::kNone;
  double ramp_s = 0.0;
  double stiffness_N_per_m = 0.0;
  std::array<std::array<double, kMaxDof>, 4> gains{};  ///< kp, kd, kv, kf (the targets).
  std::array<double, kMaxDof> normal{};
  double offset_m = 0.0;
  double offset_rate_m_per_s = 0.0;
  double normal_rate_rad_per_s = 0.0;
  control::PassivityMode passivity_mode = control::PassivityMode::kOff;
};

/// Single producer (the callers serialise themselves, TeleopNode::Impl::command_mutex), single consumer (the cycle).
class CommandQueue {
 public:
  static constexpr std::size_t kCapacity = 64;
  static constexpr int kPerCycle = 8;  ///< Drained per cycle at most (bounds the cycle's work).

  explicit CommandQueue(int dof) : dof_(dof) {}

  /// Producer side. False (counted) when the ring is full.
  bool Post(const PendingCommand& p) noexcept {
    if (ring_.TryPush(p)) return true;
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  /// The cycle's drain point: pops at most kPerCycle commands, logs each outcome as an event, and folds their
  /// changes (a later one of a kind replacing an earlier one) with the command channel's clutch into one value.
  Changes Drain(bool command_clutch, std::uint64_t cycle, EventLog& events) noexcept;
  /// Outcomes not handed to the cycle because the ring was full.
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  int dof_;
  runtime::SpscRing<PendingCommand> ring_{kCapacity};
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace teleop::node
