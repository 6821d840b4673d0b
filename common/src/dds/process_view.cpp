#include "teleop/dds/process_view.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>

namespace teleop::dds {

namespace {

/// A number for JSON: null for NaN and infinities (JSON has neither).
std::string JsonNumber(double v) { return std::isfinite(v) ? fmt::format("{}", v) : "null"; }

/// A number for CSV and the table: empty / "-" when unknown.
std::string CsvNumber(double v) { return std::isfinite(v) ? fmt::format("{}", v) : ""; }

std::string Cell(double v, const char* format) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("-");
}

/// A JSON array of the first `n` of `values`.
std::string JsonArray(const std::array<double, kMaxDof>& values, std::size_t n) {
  std::string out = "[";
  for (std::size_t i = 0; i < n && i < values.size(); ++i) {
    if (i > 0) out += ',';
    out += JsonNumber(values[i]);
  }
  out += ']';
  return out;
}

std::string Faults(const ProcessView& v) {
  if (v.device_faults == 0) return "-";
  return fmt::format("0x{:x}", v.device_faults);
}

}  // namespace

std::string ClutchText(std::uint8_t clutch) {
  if (clutch == 0) return "-";
  std::string out;
  const auto add = [&out](const char* name) {
    if (!out.empty()) out += '+';
    out += name;
  };
  if ((clutch & 1U) != 0) add("device");
  if ((clutch & 2U) != 0) add("peer");
  if ((clutch & 4U) != 0) add("command");
  if ((clutch & ~7U) != 0) add("other");
  return out;
}

const char* ToString(ProcessView::Status status) noexcept {
  switch (status) {
    case ProcessView::Status::kDiscovered:
      return "discovered";
    case ProcessView::Status::kLive:
      return "live";
    case ProcessView::Status::kStale:
      return "stale";
    case ProcessView::Status::kGone:
      return "gone";
    case ProcessView::Status::kFinished:
      return "finished";
  }
  return "unknown";
}

double StaleLimit_s(const ProcessView& view, double stale_after_s) noexcept {
  const double three_periods_s = view.state_rate_hz > 0.0 ? 3.0 / view.state_rate_hz : 0.0;
  return std::max(stale_after_s, three_periods_s);
}

ProcessView::Status StatusOf(const ProcessView& view, std::int64_t now_ns, double stale_after_s) noexcept {
  if (view.have_summary) return ProcessView::Status::kFinished;
  if (view.writer_left) return ProcessView::Status::kGone;
  if (!view.have_state) return ProcessView::Status::kDiscovered;
  const double age_s = static_cast<double>(now_ns - view.last_state_ns) * 1e-9;
  return age_s > StaleLimit_s(view, stale_after_s) ? ProcessView::Status::kStale : ProcessView::Status::kLive;
}

std::string FormatTable(const std::vector<ProcessView>& views) {
  fmt::memory_buffer out;
  constexpr const char* kRow =
      "{:<16} {:<6} {:<10} {:>6} {:>8} {:>7} {:>7} {:>8} {:<13} {:<12} {:>6} {:>6} {:>9} {:>9} {:>9} {}\n";
  fmt::format_to(std::back_inserter(out), fmt::runtime(kRow), "PAIR", "ROLE", "STATUS", "AGE_S", "RATE_HZ", "LOSS_%",
                 "LOST", "RTT_MS", "ENGAGEMENT", "CLUTCH", "FAULTS", "TRIPS", "TRACK_MM", "K_N/M", "LIMIT_N/M",
                 "LAST_EVENT");
  const double unknown = std::numeric_limits<double>::quiet_NaN();
  for (const ProcessView& v : views) {
    fmt::format_to(
        std::back_inserter(out), fmt::runtime(kRow), v.pair, v.role, ToString(v.status), Cell(v.age_s, "{:.1f}"),
        Cell(v.achieved_rate_hz, "{:.0f}"), Cell(v.loss_fraction * 100.0, "{:.2f}"), v.packets_lost,
        Cell(v.rtt_ms, "{:.3f}"), v.have_state ? ToString(v.engagement) : "-",
        v.have_state ? ClutchText(v.clutch) : "-", Faults(v), v.watchdog_trips,
        Cell(v.tracking_error_m * 1e3, "{:.3f}"), Cell(v.have_state ? v.fixture_stiffness_N_per_m : unknown, "{:.0f}"),
        Cell(v.have_state ? v.fixture_limit_N_per_m : unknown, "{:.0f}"), v.last_event.empty() ? "-" : v.last_event);
  }
  return fmt::to_string(out);
}

std::string CsvHeader() {
  return "t_s,pair,role,status,age_s,cycle,time_s,rate_hz,achieved_rate_hz,loss_fraction,packets_accepted,packets_lost,"
         "packets_rejected,rtt_ms,engagement,clutch,device_faults,overruns,watchdog_trips,tracking_error_m,"
         "fixture_penetration_m,states_received,events_received,last_event,fixture_stiffness_N_per_m,"
         "fixture_limit_N_per_m";
}

std::string CsvRow(const ProcessView& v, double t_s) {
  return fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}", t_s, v.pair,
                     v.role, ToString(v.status), CsvNumber(v.age_s), v.cycle, v.time_s, v.rate_hz,
                     CsvNumber(v.achieved_rate_hz), CsvNumber(v.loss_fraction), v.packets_accepted, v.packets_lost,
                     v.packets_rejected, CsvNumber(v.rtt_ms), v.have_state ? ToString(v.engagement) : "", v.clutch,
                     v.device_faults, v.overruns, v.watchdog_trips, CsvNumber(v.tracking_error_m),
                     CsvNumber(v.fixture_penetration_m), v.states_received, v.events_received, v.last_event,
                     CsvNumber(v.fixture_stiffness_N_per_m), CsvNumber(v.fixture_limit_N_per_m));
}

std::string JsonStateLine(const ProcessView& v, double t_s) {
  return fmt::format(
      "{{\"type\":\"state\",\"t_s\":{},\"pair\":{},\"role\":{},\"status\":\"{}\",\"age_s\":{},\"cycle\":{},"
      "\"time_s\":{},\"rate_hz\":{},\"achieved_rate_hz\":{},\"loss_fraction\":{},\"packets_accepted\":{},\"packets_"
      "lost\":{},"
      "\"packets_rejected\":{},\"rtt_ms\":{},\"engagement\":\"{}\",\"clutch\":{},\"device_faults\":{},\"overruns\":{},"
      "\"watchdog_trips\":{},\"tracking_error_m\":{},\"fixture_penetration_m\":{},\"states_received\":{},"
      "\"events_received\":{},\"last_event\":{},\"fixture_stiffness_N_per_m\":{},\"fixture_limit_N_per_m\":{},"
      "\"joint_position_rad\":{},\"joint_torque_Nm\":{}}}",
      JsonNumber(t_s), JsonString(v.pair), JsonString(v.role), ToString(v.status), JsonNumber(v.age_s), v.cycle,
      JsonNumber(v.time_s), JsonNumber(v.rate_hz), JsonNumber(v.achieved_rate_hz), JsonNumber(v.loss_fraction),
      v.packets_accepted, v.packets_lost, v.packets_rejected, JsonNumber(v.rtt_ms),
      v.have_state ? ToString(v.engagement) : "", v.clutch, v.device_faults, v.overruns, v.watchdog_trips,
      JsonNumber(v.tracking_error_m), JsonNumber(v.fixture_penetration_m), v.states_received, v.events_received,
      JsonString(v.last_event), JsonNumber(v.fixture_stiffness_N_per_m), JsonNumber(v.fixture_limit_N_per_m),
      JsonArray(v.joint_position_rad, v.joints), JsonArray(v.joint_torque_Nm, v.joints));
}

std::string JsonSummaryLine(const ProcessView& v, double t_s) {
  return fmt::format(
      "{{\"type\":\"summary\",\"t_s\":{},\"pair\":{},\"role\":{},\"stop_reason\":{},\"cycles\":{},"
      "\"packets_accepted\":{},\"packets_lost\":{},\"rtt_p50_ms\":{},\"rtt_max_ms\":{},\"summary_json\":{}}}",
      JsonNumber(t_s), JsonString(v.pair), JsonString(v.role), JsonString(v.stop_reason), v.summary_cycles,
      v.summary_packets_accepted, v.summary_packets_lost, JsonNumber(v.summary_rtt_p50_ms),
      JsonNumber(v.summary_rtt_max_ms), JsonString(v.summary_json));
}

std::string JsonEventLine(const std::string& pair, const std::string& role, const std::string& kind_name,
                          std::uint64_t cycle, double value, double t_s) {
  return fmt::format("{{\"type\":\"event\",\"t_s\":{},\"pair\":{},\"role\":{},\"kind\":{},\"cycle\":{},\"value\":{}}}",
                     JsonNumber(t_s), JsonString(pair), JsonString(role), JsonString(kind_name), cycle,
                     JsonNumber(value));
}

}  // namespace teleop::dds
