#include "teleop/node/connection_watch.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "teleop/runtime/background_thread.hpp"
#include "teleop/version.hpp"

namespace teleop::node {

namespace {

using transport::SecureReceiveStatus;

std::uint64_t Secure(const transport::LinkCounters& c, SecureReceiveStatus status) noexcept {
  return c.secure_rejected_by_reason[static_cast<std::size_t>(status)];
}

const char* PeerName(Role role) noexcept { return role == Role::kMaster ? "slave" : "master"; }

std::string Versions() {
  return fmt::format("this process runs {} (wire protocol {}, authenticated {})", SoftwareVersion(),
                     proto::kProtocolVersion, proto::kSecureProtocolVersion);
}

// Why the peer's answers are refused, when they are (the most specific first); empty when nothing says why.
std::string Refusal(const ConnectionFacts& f) {
  const unsigned v = f.peer_protocol_version;
  if (v == proto::kSecureProtocolVersion && !f.authenticated) {
    return fmt::format(
        "the peer uses an authenticated link (wire protocol {}, link.security.mode psk) and this process does not "
        "(protocol {}): set the same link.security.mode on both",
        v, proto::kProtocolVersion);
  }
  if (f.insecure_refused > 0) {
    return fmt::format(
        "the peer sends unauthenticated samples (wire protocol {}, link.security.mode insecure; {} refused) and this "
        "process requires psk: set the same link.security.mode on both",
        proto::kProtocolVersion, f.insecure_refused);
  }
  if (v != 0) {
    return fmt::format(
        "the peer runs wire protocol version {} and {}: refused ({} datagrams); run the same "
        "software on both (--version)",
        v, Versions(), f.bad_version);
  }
  if (f.bad_handshake_tag > 0) {
    return fmt::format(
        "the peer answers but its key differs ({} handshakes refused: bad tag); copy the same "
        "teleop-keygen file to both",
        f.bad_handshake_tag);
  }
  if (f.dof_mismatches > 0) {
    return fmt::format("the peer's samples carry another DOF count ({} refused); check both configs' dof",
                       f.dof_mismatches);
  }
  if (f.wrong_sender > 0) {
    return fmt::format("{} datagrams came from the wrong role or address; check link.peer_address/peer_port on both",
                       f.wrong_sender);
  }
  return {};
}

}  // namespace

void FillFromCounters(const transport::LinkCounters& c, ConnectionFacts& f) noexcept {
  f.sent = c.sent;
  f.received = c.received;
  f.accepted = c.accepted;
  f.rejected = c.rejected;
  f.handshakes_started = c.handshakes_started;
  f.handshake_messages = c.handshake_messages;
  f.sessions = c.sessions;
  f.bad_handshake_tag = Secure(c, SecureReceiveStatus::kBadHandshakeTag);
  f.insecure_refused = Secure(c, SecureReceiveStatus::kInsecure);
  f.bad_version = c.rejected_by_reason[static_cast<std::size_t>(proto::DecodeStatus::kBadVersion)] +
                  Secure(c, SecureReceiveStatus::kMalformed);
  f.wrong_sender = c.wrong_sender + Secure(c, SecureReceiveStatus::kWrongSender);
  f.unreachable = c.bus_errors;
  f.peer_protocol_version = c.peer_protocol_version;
}

std::string DescribeConnection(const ConnectionFacts& f) {
  if (f.connected) return "connected";
  const bool udp = f.transport == "udp";
  const std::string peer =
      fmt::format("the {} {}{}", PeerName(f.role), udp ? "at " : "on ", udp ? f.peer_address : f.transport);
  std::string head = fmt::format("waiting for {} ({:.1f} s)", peer, f.waited_s);
  if (std::string why = Refusal(f); !why.empty()) return head + ": " + why;
  if (f.accepted > 0 || f.sessions > 0) {
    return head +
           fmt::format(": {} samples accepted, {} sessions, but the peer is not usable yet", f.accepted, f.sessions);
  }
  if (f.received > 0) {
    return head + fmt::format(": {} datagrams received, {} refused, none usable (the summary lists why)", f.received,
                              f.rejected);
  }
  std::string what;  // what this side sent, and that nothing came back
  if (!f.authenticated) {
    what = fmt::format("{} samples sent, no answer", f.sent);
  } else if (f.role == Role::kMaster) {
    what = fmt::format("{} hellos sent, no answer", f.handshakes_started);
  } else {
    what = "no hello received";
  }
  if (udp && f.unreachable > 0) {
    return head + fmt::format(
                      ": {}; {} answered 'port unreachable': nothing listens at {} (is it running? is the "
                      "port right?)",
                      what, f.unreachable, f.peer_address);
  }
  const char* hint = f.role == Role::kSlave && f.authenticated
                         ? " (is the master running? does its link.peer name this host? a firewall?)"
                     : f.authenticated ? " (is it running? is the address right? a firewall? the same key?)"
                                       : " (is it running? is the address right? a firewall?)";
  return head + ": " + what + hint;
}

ConnectionWatch::ConnectionWatch(Config config, std::function<void()> give_up)
    : config_(std::move(config)), give_up_(std::move(give_up)) {
  decimation_ = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::lround(config_.rate_hz / 10.0)));
  // Started here, before the node's Activate: the thread keeps the scheduling the process started with.
  thread_ = std::thread([this] { Watch(); });
}

ConnectionWatch::~ConnectionWatch() { StopThread(); }

void ConnectionWatch::StopThread() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void ConnectionWatch::OnCycle(const CycleRecord& record) noexcept {
  if (record.peer_fresh && !connected_.load(std::memory_order_relaxed)) {
    connected_.store(true, std::memory_order_relaxed);
  }
  const runtime::TelemetryRecord& row = *record.telemetry;
  if (row.cycle % decimation_ != 0) return;
  const transport::LinkCounters& c = *record.link;
  const std::uint64_t values[kSlots] = {
      c.sent,
      c.received,
      c.accepted,
      c.rejected,
      c.handshakes_started,
      c.handshake_messages,
      c.sessions,
      Secure(c, SecureReceiveStatus::kBadHandshakeTag),
      Secure(c, SecureReceiveStatus::kInsecure),
      c.rejected_by_reason[static_cast<std::size_t>(proto::DecodeStatus::kBadVersion)] +
          Secure(c, SecureReceiveStatus::kMalformed),
      c.wrong_sender + Secure(c, SecureReceiveStatus::kWrongSender),
      c.bus_errors,
      c.peer_protocol_version,
  };
  for (std::size_t i = 0; i < kSlots; ++i) slots_[i].store(values[i], std::memory_order_relaxed);
  waited_ns_.store(static_cast<std::uint64_t>(std::max(row.time_s, 0.0) * 1e9), std::memory_order_relaxed);
  usable_now_.store(record.peer_fresh, std::memory_order_relaxed);
  started_.store(true, std::memory_order_release);
}

ConnectionFacts ConnectionWatch::Snapshot() const {
  ConnectionFacts f = config_.base;
  const auto at = [this](Slot s) { return slots_[s].load(std::memory_order_relaxed); };
  f.sent = at(kSent);
  f.received = at(kReceived);
  f.accepted = at(kAccepted);
  f.rejected = at(kRejected);
  f.handshakes_started = at(kHandshakesStarted);
  f.handshake_messages = at(kHandshakeMessages);
  f.sessions = at(kSessions);
  f.bad_handshake_tag = at(kBadHandshakeTag);
  f.insecure_refused = at(kInsecureRefused);
  f.bad_version = at(kBadVersion);
  f.wrong_sender = at(kWrongSender);
  f.unreachable = at(kUnreachable);
  f.peer_protocol_version = static_cast<std::uint8_t>(at(kPeerVersion));
  f.connected = connected_.load(std::memory_order_relaxed);
  f.waited_s = static_cast<double>(waited_ns_.load(std::memory_order_relaxed)) * 1e-9;
  return f;
}

void ConnectionWatch::Watch() {
  runtime::BecomeBackgroundThread("teleop-connect");
  using Clock = std::chrono::steady_clock;
  constexpr auto kTick = std::chrono::milliseconds(100);
  Clock::time_point next_status{};
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, kTick, [this] { return stop_; })) {
    if (!started_.load(std::memory_order_acquire)) continue;
    const ConnectionFacts f = Snapshot();
    if (f.connected && usable_now_.load(std::memory_order_relaxed)) continue;
    if (!f.connected && config_.connect_timeout_s > 0.0 && f.waited_s >= config_.connect_timeout_s &&
        !gave_up_.exchange(true)) {
      spdlog::error("giving up after --connect-timeout {:g} s: {}", config_.connect_timeout_s, DescribeConnection(f));
      if (give_up_) give_up_();
      continue;
    }
    const auto now = Clock::now();
    if (f.connected || config_.status_interval_s <= 0.0 || gave_up() || now < next_status) continue;
    if (next_status != Clock::time_point{}) spdlog::warn("{}", DescribeConnection(f));
    next_status =
        now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.status_interval_s));
  }
}

void ConnectionWatch::Finish(RunSummary& summary) {
  StopThread();
  ConnectionFacts f = Snapshot();
  FillFromCounters(summary.link, f);  // the final counts
  f.dof_mismatches = summary.dof_mismatches;
  f.connected = f.connected || summary.cycles_with_peer > 0;
  summary.connected = f.connected;
  summary.connection = f.connected ? "connected" : "NEVER CONNECTED: " + DescribeConnection(f);
  if (gave_up()) summary.stop_reason = "connect timeout";
}

}  // namespace teleop::node
