#pragma once

// The Modbus I/O thread (docs/modbus.md): a non-real-time thread owns the bus (libmodbus, TCP or RTU) and exchanges
// the newest command and the newest reading with the control loop through two wait-free mailboxes.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <thread>

#include "teleop/device/device.hpp"
#include "teleop/fieldbus/modbus_config.hpp"
#include "teleop/runtime/mailbox.hpp"

namespace teleop::fieldbus {

/// What the loop wants written: SI values in the order of ModbusConfig::outputs (entries past outputs.size() unused).
struct ModbusCommand {
  std::array<double, kMaxModbusPoints> values{};
};

/// What the bus said: SI values in the order of ModbusConfig::inputs, from the newest complete poll.
struct ModbusReading {
  std::array<double, kMaxModbusPoints> values{};
  /// Complete successful polls so far; 0 = none yet (values are zeros then).
  std::uint64_t sequence = 0;
  /// When the poll that produced `values` completed (ModbusIoThread::NowS() clock, s); NaN before the first.
  double stamp_s = std::numeric_limits<double>::quiet_NaN();
  /// device::kFaultCommunication while the bus fails (set by the I/O thread on the first failed transaction, or by
  /// LatestReading() when the reading is older than stale_after_ms); kFaultNone otherwise.
  std::uint32_t faults = device::kFaultNone;
  /// True when the I/O thread wrote the outputs' safe values in its newest cycle (no fresh command from the loop).
  bool outputs_safe = true;
  /// Set by LatestReading(): the newest good poll is older than stale_after_ms (or there is none); faults then
  /// holds kFaultCommunication whatever the I/O thread last said.
  bool stale = true;
  /// I/O thread cycles in a row that failed (0 while healthy), when this reading was published.
  std::uint32_t failed_cycles = 0;
};

/// Every failure kind, counted (monotonic since Start()). Read with ModbusIoThread::counters() from any thread.
struct ModbusCounters {
  std::uint64_t cycles = 0;               ///< I/O thread cycles (poll attempts, also while disconnected).
  std::uint64_t polls_ok = 0;             ///< Cycles where every write and read succeeded.
  std::uint64_t transactions = 0;         ///< Requests sent.
  std::uint64_t timeouts = 0;             ///< No (complete) answer within response_timeout_ms.
  std::uint64_t exceptions = 0;           ///< Exception responses (any code).
  std::uint32_t last_exception_code = 0;  ///< Code of the newest one (1 illegal function, 2 illegal address, ...).
  std::uint64_t protocol_errors = 0;      ///< Bad CRC, bad data, wrong unit or transaction id in the answer.
  std::uint64_t disconnects = 0;          ///< Connection lost (reset, closed by the peer, I/O error).
  std::uint64_t connects = 0;             ///< Successful connects (the first one included).
  std::uint64_t connect_failures = 0;     ///< Connect/open attempts that failed.
  std::uint64_t fault_entries = 0;        ///< Transitions healthy -> kFaultCommunication in the I/O thread.
  std::uint64_t watchdog_trips = 0;       ///< I/O thread watchdog: no good poll within stale_after_ms.
  std::uint64_t command_timeouts = 0;     ///< Switches to safe outputs because the loop's command went stale.
  std::uint64_t clamped_commands = 0;     ///< Output values outside their raw range (clamped).
  std::uint64_t non_finite_commands = 0;  ///< NaN/inf output values (replaced by the safe value).
  std::uint64_t commands_received = 0;    ///< New commands the I/O thread took from the mailbox.
  std::uint64_t stale_readings = 0;       ///< LatestReading() calls that found the reading stale (loop side).
};

/// Owns one Modbus connection in its own thread.
///
/// Threading: Start()/Stop() and the destructor from a set-up thread; PublishCommand() from one thread (the loop) and
/// LatestReading() from one thread (the loop), both wait-free, no locks, no allocation, no system call beyond the
/// vDSO clock; counters() from any thread.
///
/// Fault timing: a failed transaction (timeout, exception response, disconnect, protocol error) sets
/// kFaultCommunication in the reading the I/O thread publishes at the end of that transaction, so within
/// poll_period_ms + response_timeout_ms of the failure; and whatever the thread does (blocked, starved, crashed bus
/// driver), LatestReading() reports the fault once the newest good poll is older than stale_after_ms. The fault
/// clears with the next good poll; the node latches its own safe state.
class ModbusIoThread {
 public:
  /// Validates `config` (throws teleop::Error). Does not touch the bus: Start() does.
  explicit ModbusIoThread(ModbusConfig config);
  /// Stop().
  ~ModbusIoThread();
  ModbusIoThread(const ModbusIoThread&) = delete;
  ModbusIoThread& operator=(const ModbusIoThread&) = delete;

  /// Starts the I/O thread; it connects (with back-off on failure) and polls. Returns at once: a missing server is
  /// not an error here, it is a fault the loop sees. Throws teleop::Error when libmodbus cannot create the context
  /// (bad host/device spec) or the thread cannot start. Calling Start() twice is an error.
  void Start();
  /// Writes the outputs' safe values (best effort, one attempt), closes the bus and joins the thread. Idempotent.
  void Stop() noexcept;
  bool running() const noexcept { return thread_.joinable(); }
  /// Set-up only (blocks): waits until the first good poll or `timeout_s`; true when a poll succeeded. Lets a backend
  /// refuse to activate on a dead bus with a clear message instead of starting faulted.
  [[nodiscard]] bool WaitForFirstPoll(double timeout_s) const noexcept;

  // ---- loop side: wait-free -----------------------------------------------------------------------------------

  /// Hands the newest command to the I/O thread (an older unsent one is replaced: newest wins).
  void PublishCommand(const ModbusCommand& command) noexcept { commands_.Write(command); }
  /// The newest reading, with kFaultCommunication added when it is older than stale_after_ms at `now_s` (NowS()
  /// clock) or there is none yet. Returns out.faults.
  [[nodiscard]] std::uint32_t LatestReading(ModbusReading& out, double now_s) noexcept;
  /// Same, at NowS().
  [[nodiscard]] std::uint32_t LatestReading(ModbusReading& out) noexcept { return LatestReading(out, NowS()); }

  // ---- any thread ---------------------------------------------------------------------------------------------

  ModbusCounters counters() const noexcept;
  const ModbusConfig& config() const noexcept { return config_; }
  /// The clock of stamp_s and LatestReading(): std::chrono::steady_clock in s.
  static double NowS() noexcept;

 private:
  struct Bus;  // libmodbus context and the I/O thread's private state
  struct AtomicCounters;
  class Poller;  // Run()'s named steps (command, encode, connect, poll, reading, stop)
  void Run() noexcept;

  ModbusConfig config_;
  runtime::Mailbox<ModbusCommand> commands_;  // loop -> I/O thread
  runtime::Mailbox<ModbusReading> readings_;  // I/O thread -> loop
  std::unique_ptr<Bus> bus_;
  std::unique_ptr<AtomicCounters> counters_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  // Loop-side state (the single reader of readings_).
  bool loop_stale_ = false;
};

}  // namespace teleop::fieldbus
