#include "teleop/node/event_log.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <string>

#include "teleop/device/device.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::node {

namespace {

/// A device fault, with what the backend says failed (Device::FaultText) when it names it.
void LogDeviceFault(const Event& e, const device::Device* device) {
  const std::string text = device != nullptr ? device->FaultText() : std::string();
  if (text.empty()) {
    spdlog::error("cycle {}: device fault 0x{:x}, safe state", e.cycle, static_cast<unsigned>(e.value));
  } else {
    spdlog::error("cycle {}: device fault 0x{:x}, safe state: {}", e.cycle, static_cast<unsigned>(e.value), text);
  }
}

/// The peer, the link, the device and the loop.
void LogLinkEvent(const Event& e) {
  switch (e.kind) {
    case Event::Kind::kPeerConnected:
      spdlog::info("cycle {}: peer connected", e.cycle);
      break;
    case Event::Kind::kPeerLost:
      spdlog::warn("cycle {}: peer lost (watchdog), coupling off", e.cycle);
      break;
    case Event::Kind::kPeerRecovered:
      spdlog::info("cycle {}: peer back, coupling on", e.cycle);
      break;
    case Event::Kind::kPeerShutdown:
      spdlog::info("cycle {}: peer is shutting down", e.cycle);
      break;
    case Event::Kind::kPeerFault:
      spdlog::warn("cycle {}: peer reports a fault, coupling off", e.cycle);
      break;
    case Event::Kind::kDeviceFaultCleared:
      spdlog::info("cycle {}: device fault cleared", e.cycle);
      break;
    case Event::Kind::kNonFiniteInput:
      spdlog::error("cycle {}: non-finite law input, zero command", e.cycle);
      break;
    case Event::Kind::kOverrun:
      spdlog::warn("cycle {}: overrun ({} so far)", e.cycle, e.value);
      break;
    case Event::Kind::kNewSession:
      spdlog::info("cycle {}: new link session (epoch {}), re-engaging through aligning", e.cycle, e.value);
      break;
    case Event::Kind::kLatencyGate:
      spdlog::warn("cycle {}: round trip {:.3f} ms above engagement.max_rtt_ms, latency gate closed", e.cycle, e.value);
      break;
    case Event::Kind::kDeviceWarning:
      if (e.value == 0.0) {
        spdlog::info("cycle {}: device warnings cleared", e.cycle);
      } else {
        spdlog::warn("cycle {}: device warnings 0x{:x} (informational; the node acts on none)", e.cycle,
                     static_cast<unsigned>(e.value));
      }
      break;
    default:
      break;
  }
}

/// Engagement, the clutch and re-indexing.
void LogCouplingEvent(const Event& e) {
  switch (e.kind) {
    case Event::Kind::kCouplingLost:
      spdlog::warn("cycle {}: coupling off ({}), safe-state reaction latched", e.cycle,
                   ToString(static_cast<Outage>(static_cast<int>(e.value))));
      break;
    case Event::Kind::kAligning:
      spdlog::info("cycle {}: aligning", e.cycle);
      break;
    case Event::Kind::kEngaged:
      spdlog::info("cycle {}: engaged", e.cycle);
      break;
    case Event::Kind::kClutchPressed:
      spdlog::info("cycle {}: clutch pressed (sources 0x{:x}: 1 device, 2 peer, 4 command)", e.cycle,
                   static_cast<unsigned>(e.value));
      break;
    case Event::Kind::kClutchReleased:
      spdlog::info("cycle {}: clutch released", e.cycle);
      break;
    case Event::Kind::kReindexed:
      spdlog::info("cycle {}: re-indexed, offset up to {:.4f} m", e.cycle, e.value);
      break;
    default:
      break;
  }
}

/// The delay re-check's outcomes (config/delay_recheck.hpp).
void LogDelayRecheck(const Event& e) {
  switch (static_cast<DelayRecheckDetail>(e.detail)) {
    case DelayRecheckDetail::kSlower:
      spdlog::warn("cycle {}: delay re-check: the link is slower, fixture ramps to {:.0f} N/m", e.cycle, e.value);
      break;
    case DelayRecheckDetail::kRecovered:
      spdlog::info("cycle {}: delay re-check: the link recovered, fixture ramps back to {:.0f} N/m", e.cycle, e.value);
      break;
    case DelayRecheckDetail::kCouplingUnstable:
      spdlog::error("cycle {}: delay re-check: no fixture is stable at the measured delay, nothing changed", e.cycle);
      break;
    case DelayRecheckDetail::kDecoupled:
      spdlog::error("cycle {}: delay re-check: no fixture is stable at the measured delay, decoupled (clutch)",
                    e.cycle);
      break;
    case DelayRecheckDetail::kPassivityOn:
      spdlog::error(
          "cycle {}: delay re-check: no fixture is stable at the measured delay, passivity controller on "
          "(observer)",
          e.cycle);
      break;
    case DelayRecheckDetail::kPassivityRestored:
      spdlog::info("cycle {}: delay re-check: stable at the measured delay again, passivity back to its config",
                   e.cycle);
      break;
    case DelayRecheckDetail::kFailed:
      spdlog::warn("cycle {}: delay re-check: nothing changed (see the re-check's message)", e.cycle);
      break;
  }
}

/// The run-time limit at an arm's configuration (config/configuration_limit.hpp).
void LogConfigurationLimit(const Event& e) {
  switch (static_cast<ConfigurationLimitDetail>(e.detail)) {
    case ConfigurationLimitDetail::kLowered:
      spdlog::warn(
          "cycle {}: configuration limit: the limit at the arm's configuration fell, fixture ramps to "
          "{:.0f} N/m",
          e.cycle, e.value);
      break;
    case ConfigurationLimitDetail::kRaised:
      spdlog::info("cycle {}: configuration limit: the limit rose, fixture ramps up to {:.0f} N/m", e.cycle, e.value);
      break;
    case ConfigurationLimitDetail::kRestored:
      spdlog::info("cycle {}: configuration limit: fixture ramps back to {:.0f} N/m", e.cycle, e.value);
      break;
    case ConfigurationLimitDetail::kFailed:
      spdlog::warn("cycle {}: configuration limit: nothing changed (see its message)", e.cycle);
      break;
  }
}

/// The command channel's outcomes.
void LogCommandEvent(const Event& e) {
  switch (e.kind) {
    case Event::Kind::kCommandAccepted:
      spdlog::info("cycle {}: command accepted: fixture stiffness {:.0f} N/m", e.cycle, e.value);
      break;
    case Event::Kind::kCommandRefused:
      spdlog::warn("cycle {}: command refused (predicted limit {:.0f} N/m)", e.cycle, e.value);
      break;
    case Event::Kind::kCommandMalformed:
      spdlog::warn("cycle {}: command malformed (nothing changed)", e.cycle);
      break;
    case Event::Kind::kCommandPeerRefused:
      spdlog::warn("cycle {}: command refused: peer uid {:.0f} is not admitted", e.cycle, e.value);
      break;
    case Event::Kind::kClutchCommanded:
      spdlog::info("cycle {}: command: clutch {}", e.cycle, e.value != 0.0 ? "on" : "off");
      break;
    case Event::Kind::kGainAccepted:
    case Event::Kind::kGainRefused: {
      const unsigned axis = e.detail % 16u;
      const char* name = ToString(static_cast<GainName>(e.detail / 16u));
      if (e.kind == Event::Kind::kGainAccepted) {
        spdlog::info("cycle {}: command accepted: gain {} axis {} = {}", e.cycle, name,
                     axis == kAllAxes ? std::string("all") : std::to_string(axis), e.value);
      } else {
        spdlog::warn("cycle {}: command refused: gain {} axis {} (predicted fixture limit {:.0f} N/m)", e.cycle, name,
                     axis == kAllAxes ? std::string("all") : std::to_string(axis), e.value);
      }
      break;
    }
    case Event::Kind::kPlaneAccepted:
      spdlog::info("cycle {}: command accepted: fixture plane to offset {:.4f} m (slewing)", e.cycle, e.value);
      break;
    case Event::Kind::kPlaneRefused:
      spdlog::warn("cycle {}: command refused: fixture plane", e.cycle);
      break;
    case Event::Kind::kDelayRecheck:
      LogDelayRecheck(e);
      break;
    case Event::Kind::kConfigurationLimit:
      LogConfigurationLimit(e);
      break;
    default:
      break;
  }
}

}  // namespace

EventLog::EventLog(std::size_t capacity)
    : ring_(capacity), thread_([this] {
        runtime::BecomeBackgroundThread("teleop-events");
        while (!stop_.load(std::memory_order_acquire)) {
          Drain();
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        Drain();
      }) {}

EventLog::~EventLog() { Stop(); }

void EventLog::Stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
  if (const auto d = dropped(); d > 0) spdlog::warn("event log: {} events dropped (ring full)", d);
}

void EventLog::Drain() {
  Event e;
  while (ring_.TryPop(e)) {
    switch (e.kind) {  // every kind named: a new one must be given a group
      case Event::Kind::kPeerConnected:
      case Event::Kind::kPeerLost:
      case Event::Kind::kPeerRecovered:
      case Event::Kind::kPeerShutdown:
      case Event::Kind::kPeerFault:
      case Event::Kind::kDeviceFaultCleared:
      case Event::Kind::kNonFiniteInput:
      case Event::Kind::kOverrun:
      case Event::Kind::kNewSession:
      case Event::Kind::kLatencyGate:
      case Event::Kind::kDeviceWarning:
        LogLinkEvent(e);
        break;
      case Event::Kind::kDeviceFault:
        LogDeviceFault(e, device_.load(std::memory_order_acquire));
        break;
      case Event::Kind::kCouplingLost:
      case Event::Kind::kAligning:
      case Event::Kind::kEngaged:
      case Event::Kind::kClutchPressed:
      case Event::Kind::kClutchReleased:
      case Event::Kind::kReindexed:
        LogCouplingEvent(e);
        break;
      case Event::Kind::kCommandAccepted:
      case Event::Kind::kCommandRefused:
      case Event::Kind::kCommandMalformed:
      case Event::Kind::kCommandPeerRefused:
      case Event::Kind::kClutchCommanded:
      case Event::Kind::kGainAccepted:
      case Event::Kind::kGainRefused:
      case Event::Kind::kPlaneAccepted:
      case Event::Kind::kPlaneRefused:
      case Event::Kind::kDelayRecheck:
      case Event::Kind::kConfigurationLimit:
        LogCommandEvent(e);
        break;
    }
    if (EventObserver* observer = observer_.load(std::memory_order_acquire)) observer->OnEvent(e);
  }
}

}  // namespace teleop::node
