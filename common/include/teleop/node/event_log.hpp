#pragma once

#include <atomic>
#include <cstdint>
#include <thread>

#include "teleop/runtime/spsc_ring.hpp"

namespace teleop::device {
class Device;
}  // namespace teleop::device

namespace teleop::node {

/// Something the loop wants a human to read. Logged by a non-real-time thread, never from the cycle.
struct Event {
  enum class Kind : std::uint8_t {
    kPeerConnected,
    kPeerLost,
    kPeerRecovered,
    kPeerShutdown,
    kPeerFault,
    kDeviceFault,
    kDeviceFaultCleared,
    kNonFiniteInput,
    kOverrun,
    kNewSession,    ///< value: the link's session epoch.
    kLatencyGate,   ///< value: the round trip (ms).
    kCouplingLost,  ///< value: the node::Outage.
    kAligning,
    kEngaged,          ///< value: the longest aligning so far (s).
    kDeviceWarning,    ///< The device's warning word changed; value: the new device::WarningBits (0: cleared).
    kClutchPressed,    ///< value: who pressed it (ClutchSource bits: 1 device, 2 peer, 4 command).
    kClutchReleased,   ///< value: the sources still pressed (0: released).
    kReindexed,        ///< The master re-indexed on release; value: the largest |offset| on an axis (m).
    kCommandAccepted,  ///< A run-time fixture stiffness change the check accepted; value: the stiffness (N/m).
    kCommandRefused,   ///< ... it refused; value: the predicted limit (N/m; 0: not analysed).
    // The command channel's other outcomes (docs/clutch.md, "Run-time commands"); `detail` says which command.
    kCommandMalformed,    ///< A command that did not parse; nothing changed. value: 0.
    kCommandPeerRefused,  ///< A peer SO_PEERCRED did not admit; value: its uid.
    kClutchCommanded,     ///< `clutch on|off`; value: 1 on, 0 off.
    kGainAccepted,        ///< A law gain change the check accepted; value: the gain; detail: GainDetail.
    kGainRefused,         ///< ... refused; value: the predicted fixture limit with it (N/m; 0: not analysed).
    kPlaneAccepted,       ///< A fixture plane move accepted; value: the target offset (m).
    kPlaneRefused,        ///< ... refused; value: 0.
    /// The run-time delay re-check acted (docs/stability.md, "Run-time re-check"); value: the fixture stiffness it
    /// ramps to (N/m); detail: DelayRecheckDetail.
    kDelayRecheck,
    /// The run-time limit at the device's configuration acted (docs/arms.md, "Stability"); value: the fixture
    /// stiffness it ramps to (N/m); detail: ConfigurationLimitDetail.
    kConfigurationLimit,
  };
  Kind kind = Kind::kPeerConnected;
  std::uint64_t cycle = 0;
  double value = 0.0;        ///< Kind-specific: fault bits, overrun count, ...
  std::uint16_t detail = 0;  ///< Kind-specific (the gain events: GainDetail); not on DDS.
};

/// What a kDelayRecheck event says.
enum class DelayRecheckDetail : std::uint16_t {
  kSlower = 0,             ///< The link got slower: the fixture ramps down to the limit at the measured delay.
  kRecovered = 1,          ///< The link recovered: the fixture ramps back to the configured stiffness.
  kCouplingUnstable = 2,   ///< No fixture is stable at the measured delay; link.delay_recheck.on_unstable: event.
  kDecoupled = 3,          ///< ... on_unstable: decouple: the command clutch is pressed.
  kFailed = 4,             ///< The re-check or the node refused (the log says why); nothing changed.
  kPassivityOn = 5,        ///< ... on_unstable: passivity: the passivity controller switched on (observer).
  kPassivityRestored = 6,  ///< The coupling is stable again at the measured delay: passivity back to its config.
};

/// What a kConfigurationLimit event says.
enum class ConfigurationLimitDetail : std::uint16_t {
  kLowered = 0,   ///< The limit at the configuration fell: the fixture ramps down below it.
  kRaised = 1,    ///< It rose again: the fixture ramps up, still below the configured stiffness.
  kRestored = 2,  ///< It rose enough: the fixture ramps back to the configured stiffness.
  kFailed = 3,    ///< The evaluation or the node refused (the log says why); nothing changed.
};

/// Which law gain a gain event names: `detail` = gain index · 16 + axis (axis 15: every axis).
enum class GainName : std::uint8_t { kKp, kKd, kKv, kKf };
inline constexpr std::uint16_t kAllAxes = 15;
inline std::uint16_t GainDetail(GainName name, int axis) noexcept {
  return static_cast<std::uint16_t>(static_cast<unsigned>(name) * 16u +
                                    (axis < 0 ? kAllAxes : static_cast<unsigned>(axis)));
}
/// The config key of a gain: kp_N_per_m, kd_Ns_per_m, kv_Ns_per_m, kf.
inline const char* ToString(GainName name) noexcept {
  switch (name) {
    case GainName::kKp:
      return "kp_N_per_m";
    case GainName::kKd:
      return "kd_Ns_per_m";
    case GainName::kKv:
      return "kv_Ns_per_m";
    case GainName::kKf:
      return "kf";
  }
  return "?";
}

/// Sees every event on the log's thread, after it is logged (the DDS bridge, docs/dds.md). Never called from the
/// real-time cycle; must not block for long.
class EventObserver {
 public:
  virtual ~EventObserver() = default;
  virtual void OnEvent(const Event& event) noexcept = 0;
};

/// The loop's log: TryPush from the real-time thread (drops are counted), a thread drains it into spdlog.
class EventLog {
 public:
  explicit EventLog(std::size_t capacity);
  ~EventLog();
  EventLog(const EventLog&) = delete;
  EventLog& operator=(const EventLog&) = delete;

  void Push(const Event& event) noexcept {
    if (!ring_.TryPush(event)) dropped_.fetch_add(1, std::memory_order_relaxed);
  }
  /// Drains what is left and joins the thread.
  void Stop();
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  /// Adds an observer (nullptr removes it); it must stay alive until Stop() returns.
  void SetObserver(EventObserver* observer) noexcept { observer_.store(observer, std::memory_order_release); }
  /// The device whose Device::FaultText a device-fault event's line carries (nullptr: the fault bits only); it must
  /// stay alive until Stop() returns.
  void SetDevice(const device::Device* device) noexcept { device_.store(device, std::memory_order_release); }

 private:
  void Drain();
  runtime::SpscRing<Event> ring_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<EventObserver*> observer_{nullptr};
  std::atomic<const device::Device*> device_{nullptr};
  std::thread thread_;
};

}  // namespace teleop::node
