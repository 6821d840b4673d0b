#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "teleop/dds/bridge_sample.hpp"
#include "teleop/json_text.hpp"
#include "teleop/types.hpp"

namespace teleop::dds {

/// What teleop-supervise knows of one process on the domain: the newest State of rt/teleop/<pair>/<role>/state,
/// the events and the run summary (docs/dds.md, "teleop-supervise"). Plain data, filled by dds::Supervisor.
struct ProcessView {
  /// How the process looks from the supervisor.
  enum class Status : std::uint8_t {
    kDiscovered,  ///< Its topic is on the domain, no State received yet.
    kLive,        ///< State received within the staleness limit.
    kStale,       ///< No State for longer than the limit (killed, hung, or the network is down).
    kGone,        ///< Its writer left the domain without a run summary.
    kFinished,    ///< It published its run summary (a clean stop).
  };

  std::string pair;
  std::string role;

  // The newest State.
  bool have_state = false;
  std::int64_t last_state_ns = 0;  ///< Supervisor's monotonic clock when it arrived.
  std::uint64_t states_received = 0;
  std::uint64_t cycle = 0;
  double time_s = 0.0;  ///< The process's loop time of that cycle (since its first cycle).
  double rate_hz = 0.0;
  double achieved_rate_hz = 0.0;  ///< NaN when unknown.
  double state_rate_hz = 0.0;
  double loss_fraction = 0.0;  ///< Over the last state period; NaN when nothing arrived.
  double rtt_ms = 0.0;         ///< NaN when unknown.
  Engagement engagement = Engagement::kWaiting;
  std::uint32_t flags = 0;
  std::uint32_t device_faults = 0;
  std::uint64_t overruns = 0;
  std::uint64_t watchdog_trips = 0;
  std::uint64_t packets_accepted = 0;
  std::uint64_t packets_lost = 0;
  std::uint64_t packets_rejected = 0;
  double tracking_error_m = 0.0;
  double fixture_penetration_m = 0.0;
  std::uint8_t clutch = 0;                 ///< Clutch sources held (1 device, 2 peer, 4 command channel; 0: released).
  double fixture_stiffness_N_per_m = 0.0;  ///< The fixture stiffness in use (0: none).
  double fixture_limit_N_per_m = std::numeric_limits<double>::quiet_NaN();  ///< NaN: no limit computed.
  std::uint8_t joints = 0;  ///< Joints of a device made of joints (0: a Cartesian device); entries below.
  std::array<double, kMaxDof> joint_position_rad{};  ///< rad (m for a prismatic joint).
  std::array<double, kMaxDof> joint_torque_Nm{};     ///< N·m (N for a prismatic joint).

  // Events.
  std::uint64_t events_received = 0;
  std::string last_event;  ///< kind_name of the newest event; empty when none.

  // Liveliness.
  bool writer_matched = false;  ///< The state writer is currently matched with the supervisor's reader.
  bool writer_left = false;     ///< It was matched and no longer is (left the domain, or its lease expired).

  // The run summary, once published.
  bool have_summary = false;
  std::string stop_reason;
  std::uint64_t summary_cycles = 0;
  std::uint64_t summary_packets_accepted = 0;
  std::uint64_t summary_packets_lost = 0;
  double summary_rtt_p50_ms = 0.0;
  double summary_rtt_max_ms = 0.0;
  std::string summary_json;

  Status status = Status::kDiscovered;  ///< Filled by StatusOf at snapshot time.
  double age_s = 0.0;                   ///< Since the newest State, at snapshot time; NaN without one.
};

const char* ToString(ProcessView::Status status) noexcept;

/// How long without a State makes a process stale: `stale_after_s`, but never below three state periods.
double StaleLimit_s(const ProcessView& view, double stale_after_s) noexcept;

/// The status of `view` at supervisor time `now_ns`: finished (summary), gone (writer left), stale (no State
/// within StaleLimit_s), live, or discovered (no State yet).
ProcessView::Status StatusOf(const ProcessView& view, std::int64_t now_ns, double stale_after_s) noexcept;

/// The clutch column: "-" when released, else the sources held joined by '+' ("device", "peer", "command").
std::string ClutchText(std::uint8_t clutch);

/// The live terminal table: one header line and one line per process, fixed-width columns.
std::string FormatTable(const std::vector<ProcessView>& views);
/// Recording: CSV (header + one row per process and refresh) or JSON lines ({"type":"state", ...}).
std::string CsvHeader();
std::string CsvRow(const ProcessView& view, double t_s);
std::string JsonStateLine(const ProcessView& view, double t_s);
/// A summary record ({"type":"summary", ...}), written once when a summary arrives.
std::string JsonSummaryLine(const ProcessView& view, double t_s);
/// An event record ({"type":"event", ...}).
std::string JsonEventLine(const std::string& pair, const std::string& role, const std::string& kind_name,
                          std::uint64_t cycle, double value, double t_s);
/// `text` as a JSON string literal (quotes included): the project's one escaper (teleop/json_text.hpp).
using teleop::JsonString;

}  // namespace teleop::dds
