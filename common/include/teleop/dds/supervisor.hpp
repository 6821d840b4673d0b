#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/dds/process_view.hpp"
#include "teleop/dds/state_trace.hpp"

namespace teleop::dds {

/// Longest text kept from a sample (event kind, stop reason) for the record and the terminal.
inline constexpr std::size_t kMaxSafeTextLength = 64;

/// Text a sample carries (anyone on the domain can publish one, docs/security.md "DDS") made safe for the CSV record
/// and the terminal table: every byte outside printable ASCII (control characters, ESC sequences, newlines, UTF-8)
/// and the CSV/JSON specials `,` `"` `\` become `?`; longer than kMaxSafeTextLength, it is cut and ends in "...".
/// Names the node publishes (peer_lost, duration, ...) pass unchanged.
std::string SafeText(std::string_view text);

/// The reading side of the bridge (teleop-supervise, docs/dds.md): joins a DDS domain, discovers every
/// rt/teleop/<pair>/<role>/{state,events,summary} topic from the built-in publication topic, subscribes to each with
/// the bridge's QoS, and keeps a ProcessView per process. Single-threaded: call Poll() every few tens of ms.
class Supervisor {
 public:
  struct Config {
    int domain_id = 0;
    double stale_after_s = 1.0;  ///< No State for this long (at least three state periods): stale.
    /// Pairs followed at most (the first discovered); the topics of any further pair are counted and ignored, so
    /// that whoever can publish on the domain cannot grow the supervisor's memory or its messages without bound.
    std::size_t max_pairs = 64;
  };
  /// Called from Poll() for every event and every run summary as it arrives (for recording).
  struct Observer {
    std::function<void(const ProcessView& view, const std::string& kind_name, std::uint64_t cycle, double value)>
        on_event;
    std::function<void(const ProcessView& view)> on_summary;
    /// Called from Poll() for every State sample, after `view` was updated with it (the dashboard's traces).
    std::function<void(const ProcessView& view, const StateTrace& trace)> on_state;
  };

  /// Throws teleop::Error when the domain cannot be joined.
  explicit Supervisor(const Config& config, Observer observer = {});
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  /// Discovers new topics and takes every new sample. Never blocks.
  void Poll();
  /// Every process seen so far, sorted by pair then role, with status and age at `now_ns` (monotonic clock).
  std::vector<ProcessView> Snapshot(std::int64_t now_ns) const;
  /// Topics discovered but not followed: of pairs beyond Config::max_pairs.
  std::uint64_t topics_ignored() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace teleop::dds
