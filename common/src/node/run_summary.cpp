#include "teleop/node/run_summary.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/json_text.hpp"

namespace teleop::node {

Distribution FromHistogram(const runtime::LatencyHistogram& histogram, double ns_per_unit) noexcept {
  Distribution d;
  d.count = histogram.count();
  d.p50 = static_cast<double>(histogram.Percentile(0.50)) / ns_per_unit;
  d.p99 = static_cast<double>(histogram.Percentile(0.99)) / ns_per_unit;
  d.max = static_cast<double>(histogram.max_ns()) / ns_per_unit;
  return d;
}

namespace {

// JSON has no NaN/inf: write null for them.
std::string Num(double v) { return std::isfinite(v) ? fmt::format("{:.9g}", v) : std::string("null"); }

std::string RejectedJson(const transport::LinkCounters& c) {
  std::string out = "{";
  bool first = true;
  for (std::size_t i = 1; i < c.rejected_by_reason.size(); ++i) {
    if (!first) out += ", ";
    first = false;
    out += fmt::format(R"("{}": {})", proto::ToString(static_cast<proto::DecodeStatus>(i)), c.rejected_by_reason[i]);
  }
  return out + "}";
}

std::string SecureRejectedJson(const transport::LinkCounters& c) {
  std::string out = "{";
  for (std::size_t i = 0; i < c.secure_rejected_by_reason.size(); ++i) {
    const auto status = static_cast<transport::SecureReceiveStatus>(i);
    if (status == transport::SecureReceiveStatus::kSample || status == transport::SecureReceiveStatus::kHandshake) {
      continue;
    }
    out += fmt::format(R"({}"{}": {})", out.size() > 1 ? ", " : "", transport::ToString(status),
                       c.secure_rejected_by_reason[i]);
  }
  return out + "}";
}

// "psk: 1 session, ..." or the insecure warning, for the text summary.
std::string SecurityText(const RunSummary& s) {
  const auto& l = s.link;
  if (s.link_security != "psk") {
    return "INSECURE (link.security.mode " + s.link_security + "): messages were not authenticated";
  }
  std::string out =
      fmt::format("psk: sessions {}, handshakes started {}, handshake messages {}, unsent (no session) {}", l.sessions,
                  l.handshakes_started, l.handshake_messages, l.send_no_session);
  std::string refused;
  for (std::size_t i = 0; i < l.secure_rejected_by_reason.size(); ++i) {
    if (l.secure_rejected_by_reason[i] == 0) continue;
    refused += fmt::format("{}{} {}", refused.empty() ? "" : ", ",
                           transport::ToString(static_cast<transport::SecureReceiveStatus>(i)),
                           l.secure_rejected_by_reason[i]);
  }
  out += "; refused: " + (refused.empty() ? "none" : refused);
  if (l.secure_rejected_by_reason[static_cast<std::size_t>(transport::SecureReceiveStatus::kBadPlaintext)] > 0) {
    out += " (bad_plaintext: authentic samples of another DOF count or role; check both configs' dof)";
  }
  return out;
}

// Why the round trip was not measured, per transport.
std::string RoundTripMissing(const RunSummary& s) {
  if (s.link_transport != "udp") return "not measured (" + s.link_transport + ": CAN frames carry no timestamps)";
  if (!s.connected) return "not measured (the peer never answered)";
  return "not measured (no sample of the peer echoed one of ours)";
}

// The JSON: one table per record, its keys in output order. A field of the summary is written here once, by its key
// and its value; FormatSummaryJson lays the tables out.

std::string Json(std::uint64_t v) { return fmt::format("{}", v); }
std::string Json(std::uint32_t v) { return fmt::format("{}", v); }
std::string Json(double v) { return Num(v); }
std::string Json(bool v) { return v ? "true" : "false"; }
std::string Json(const std::string& v) { return JsonString(v); }

/// One key of a JSON object and how its value is written from the record R.
template <class R>
struct Field {
  std::string_view key;
  std::string (*json)(const R&);
};

/// The text lines of a row: none, one, or one per fault.
using Lines = std::vector<std::string>;

/// One field of the summary: its JSON key and value (`key` empty: text only), `line_end` (the JSON breaks the line
/// after it), and the text lines under `label` that phrase it (`text` null: JSON only).
struct SummaryField {
  std::string_view key;
  std::string (*json)(const RunSummary&) = nullptr;
  bool line_end = false;
  std::string_view label = {};
  Lines (*text)(const RunSummary&) = nullptr;
};

template <class R, std::size_t N>
std::string Object(const std::array<Field<R>, N>& fields, const R& record) {
  std::string out = "{";
  for (const Field<R>& f : fields)
    out += fmt::format(R"({}"{}": {})", out.size() > 1 ? ", " : "", f.key, f.json(record));
  return out + "}";
}

using D = Distribution;
constexpr auto kDistributionFields = std::to_array<Field<D>>({
    {"count", [](const D& d) { return Json(d.count); }},
    {"p50", [](const D& d) { return Json(d.p50); }},
    {"p99", [](const D& d) { return Json(d.p99); }},
    {"max", [](const D& d) { return Json(d.max); }},
});
std::string Json(const Distribution& d) { return Object(kDistributionFields, d); }

using S = RunSummary;
constexpr auto kPacketFields = std::to_array<Field<S>>({
    {"sent", [](const S& s) { return Json(s.link.sent); }},
    {"send_errors", [](const S& s) { return Json(s.link.send_errors); }},
    {"received", [](const S& s) { return Json(s.link.received); }},
    {"accepted", [](const S& s) { return Json(s.link.accepted); }},
    {"lost", [](const S& s) { return Json(s.link.lost); }},
    {"reordered", [](const S& s) { return Json(s.link.reordered); }},
    {"duplicates", [](const S& s) { return Json(s.link.duplicates); }},
    {"rejected", [](const S& s) { return Json(s.link.rejected); }},
    {"wrong_sender", [](const S& s) { return Json(s.link.wrong_sender); }},
    {"superseded", [](const S& s) { return Json(s.link.superseded); }},
    {"bus_errors", [](const S& s) { return Json(s.link.bus_errors); }},
    {"rejected_by_reason", [](const S& s) { return RejectedJson(s.link); }},
});

constexpr auto kSecurityFields = std::to_array<Field<S>>({
    {"mode", [](const S& s) { return Json(s.link_security); }},
    {"sessions", [](const S& s) { return Json(s.link.sessions); }},
    {"handshakes_started", [](const S& s) { return Json(s.link.handshakes_started); }},
    {"handshake_messages", [](const S& s) { return Json(s.link.handshake_messages); }},
    {"send_no_session", [](const S& s) { return Json(s.link.send_no_session); }},
    {"rejected_by_reason", [](const S& s) { return SecureRejectedJson(s.link); }},
});

constexpr auto kPassivityFields = std::to_array<Field<S>>({
    {"mode", [](const S& s) { return Json(s.passivity_mode); }},
    {"cycles", [](const S& s) { return Json(s.passivity_cycles); }},
    {"dissipated_J", [](const S& s) { return Json(s.passivity_dissipated_J); }},
    {"min_observed_J", [](const S& s) { return Json(s.passivity_min_observed_J); }},
    {"peer_without_energy", [](const S& s) { return Json(s.passivity_peer_without_energy); }},
});

using W = DeviceWarningSummary;
constexpr auto kDeviceWarningFields = std::to_array<Field<W>>({
    {"changes", [](const W& w) { return Json(w.changes); }},
    {"cycles", [](const W& w) { return Json(w.cycles); }},
    {"seen", [](const W& w) { return Json(w.seen); }},
    {"last", [](const W& w) { return Json(w.last); }},
});

using E = EngagementSummary;
constexpr auto kEngagementFields = std::to_array<Field<E>>({
    {"reaction", [](const E& e) { return Json(e.reaction); }},
    {"final_state", [](const E& e) { return Json(e.final_state); }},
    {"times_engaged", [](const E& e) { return Json(e.times_engaged); }},
    {"couplings_lost", [](const E& e) { return Json(e.couplings_lost); }},
    {"engaged_cycles", [](const E& e) { return Json(e.engaged_cycles); }},
    {"aligning_mean_s", [](const E& e) { return Json(e.aligning_mean_s); }},
    {"aligning_max_s", [](const E& e) { return Json(e.aligning_max_s); }},
    {"max_reengagement_step_m", [](const E& e) { return Json(e.max_reference_step_m); }},
    {"max_aligning_force_rate_N_per_s", [](const E& e) { return Json(e.max_aligning_force_rate_N_per_s); }},
    {"latency_gate_trips", [](const E& e) { return Json(e.latency_gate_trips); }},
    {"new_sessions", [](const E& e) { return Json(e.new_sessions); }},
    {"encoder_jumps", [](const E& e) { return Json(e.encoder_jumps); }},
    {"out_of_range_readings", [](const E& e) { return Json(e.out_of_range_readings); }},
    {"nonfinite_readings", [](const E& e) { return Json(e.nonfinite_readings); }},
});

using F = FaultReport;
constexpr auto kFaultFields = std::to_array<Field<F>>({
    {"kind", [](const F& f) { return Json(std::string(ToString(f.kind))); }},
    {"cycle", [](const F& f) { return Json(f.cycle); }},
    {"time_s", [](const F& f) { return Json(f.time_s); }},
    {"reaction", [](const F& f) { return Json(f.reaction); }},
    {"peer_sample_age_s", [](const F& f) { return Json(f.peer_sample_age_s); }},
    {"device_faults", [](const F& f) { return Json(f.device_faults); }},
    {"record", [](const F& f) { return Json(f.file); }},
});

// One fault per line.
std::string FaultsJson(const std::vector<FaultReport>& faults) {
  std::string out = "[";
  for (const FaultReport& f : faults) out += (out.size() == 1 ? "\n    " : ",\n    ") + Object(kFaultFields, f);
  return out + (faults.empty() ? "]" : "\n  ]");
}

std::string DataAgeCyclesJson(const std::array<std::uint64_t, 4>& cycles) {
  std::string out = "[";
  for (const std::uint64_t c : cycles) out += (out.size() > 1 ? ", " : "") + Json(c);
  return out + "]";
}

std::string Json(std::int64_t v) { return fmt::format("{}", v); }

constexpr auto kClockFields = std::to_array<Field<S>>({
    {"start_monotonic_ns", [](const S& s) { return Json(s.clock_start_monotonic_ns); }},
    {"peer_offset_ns",
     [](const S& s) { return s.peer_clock_offset_ns ? Json(*s.peer_clock_offset_ns) : std::string("null"); }},
    {"peer_offset_uncertainty_ns",
     [](const S& s) {
       return s.peer_clock_offset_ns ? Json(s.peer_clock_offset_uncertainty_ns) : std::string("null");
     }},
});

// The summary, one row per field in output order: its JSON key and value, whether the JSON line ends after it, and
// the text line(s) that phrase it (and the fields before it on its JSON line) in the units a reader expects (mm, ms).
// A row without a key is text only; one without a label JSON only. A new field is one row here.
constexpr bool kEnd = true;  // the JSON line ends after this field
constexpr auto kSummaryFields = std::to_array<SummaryField>({
    {"role", [](const S& s) { return Json(std::string(ToString(s.role))); }},
    {"software_version", [](const S& s) { return Json(s.software_version); }},
    {"protocol_version",
     [](const S& s) { return Json(static_cast<std::uint64_t>(s.protocol_version)); },
     kEnd,
     "version",
     [](const S& s) { return Lines{fmt::format("{}, wire protocol {}", s.software_version, s.protocol_version)}; }},
    {"stop_reason", [](const S& s) { return Json(s.stop_reason); }},
    {"connected", [](const S& s) { return Json(s.connected); }},
    {"connection",
     [](const S& s) { return Json(s.connection); },
     kEnd,
     "connection",
     [](const S& s) { return Lines{s.connection}; }},
    {"rate_hz", [](const S& s) { return Json(s.rate_hz); }},
    {"duration_s", [](const S& s) { return Json(s.duration_s); }},
    {"cycles", [](const S& s) { return Json(s.cycles); }},
    {"achieved_rate_hz", [](const S& s) { return Json(s.achieved_rate_hz); }},
    {"overruns",
     [](const S& s) { return Json(s.overruns); },
     kEnd,
     "cycles",
     [](const S& s) {
       return Lines{fmt::format("{} in {:.3f} s ({:.1f} Hz achieved, {:.0f} Hz configured), overruns {}", s.cycles,
                                s.duration_s, s.achieved_rate_hz, s.rate_hz, s.overruns)};
     }},
    {"period_us", [](const S& s) { return Json(s.period_us); }},
    {"jitter_us",
     [](const S& s) { return Json(s.jitter_us); },
     false,
     "period jitter",
     [](const S& s) {
       return Lines{fmt::format("p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us", s.jitter_us.p50, s.jitter_us.p99,
                                s.jitter_us.max)};
     }},
    {"compute_us",
     [](const S& s) { return Json(s.compute_us); },
     kEnd,
     "compute time",
     [](const S& s) {
       return Lines{fmt::format("p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us", s.compute_us.p50, s.compute_us.p99,
                                s.compute_us.max)};
     }},
    {"packets",
     [](const S& s) { return Object(kPacketFields, s); },
     kEnd,
     "packets",
     [](const S& s) {
       const auto& l = s.link;
       return Lines{fmt::format(
           "sent {}, received {}, accepted {}, superseded {}, lost {}, reordered {}, duplicates {}, rejected {}, send "
           "errors {}",
           l.sent, l.received, l.accepted, l.superseded, l.lost, l.reordered, l.duplicates, l.rejected, l.send_errors)};
     }},
    {"security",
     [](const S& s) { return Object(kSecurityFields, s); },
     kEnd,
     "security",
     [](const S& s) { return Lines{SecurityText(s)}; }},
    {"link_transport", [](const S& s) { return Json(s.link_transport); }},
    {"link_detail",
     [](const S& s) { return Json(s.link_detail); },
     false,
     "link detail",
     [](const S& s) { return s.link_detail.empty() ? Lines{} : Lines{s.link_detail}; }},
    {"link_fault_cycles",
     [](const S& s) { return Json(s.link_fault_cycles); },
     kEnd,
     "link faults",
     [](const S& s) {
       return s.link_fault_cycles > 0 ? Lines{fmt::format("medium down in {} cycles", s.link_fault_cycles)} : Lines{};
     }},
    {"link_emulation",
     [](const S& s) {
       return s.link_emulation ? transport::ImpairmentCountersJson(*s.link_emulation) : std::string("null");
     },
     kEnd,
     "link emulation",
     [](const S& s) {
       return s.link_emulation ? Lines{transport::FormatImpairmentCounters(*s.link_emulation)} : Lines{};
     }},
    {"rtt_ms",
     [](const S& s) { return Json(s.rtt_ms); },
     kEnd,
     "round trip",
     [](const S& s) {
       if (s.rtt_ms.count == 0) return Lines{RoundTripMissing(s)};
       return Lines{fmt::format("p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms ({} samples)", s.rtt_ms.p50, s.rtt_ms.p99,
                                s.rtt_ms.max, s.rtt_ms.count)};
     }},
    {"sync", [](const S& s) { return Json(s.sync); }},
    {"triggered_cycles", [](const S& s) { return Json(s.triggered_cycles); }},
    {"trigger_timeouts", [](const S& s) { return Json(s.trigger_timeouts); }},
    {"trigger_timeouts_coupled",
     [](const S& s) { return Json(s.trigger_timeouts_coupled); },
     kEnd,
     "sync",
     [](const S& s) {
       if (s.triggered_cycles + s.trigger_timeouts == 0) return Lines{s.sync};
       return Lines{fmt::format("{}, {} cycles triggered by the peer's sample, {} timeouts ({} while coupled)", s.sync,
                                s.triggered_cycles, s.trigger_timeouts, s.trigger_timeouts_coupled)};
     }},
    {"data_age_us", [](const S& s) { return Json(s.data_age_us); }},
    {"data_age_sender_us", [](const S& s) { return Json(s.data_age_sender_us); }},
    {"data_age_cycles",
     [](const S& s) { return DataAgeCyclesJson(s.data_age_cycles); },
     kEnd,
     "data age",
     [](const S& s) {
       if (s.data_age_us.count == 0) return Lines{};
       const auto& c = s.data_age_cycles;
       // The age since the peer sent needs the peers' clock offset, which comes from the round trip: where that is
       // not measured (CAN), neither is this age (it is not 0).
       const std::string sent = s.data_age_sender_us.count == 0
                                    ? std::string("since the peer sent not measured (no round trip)")
                                    : fmt::format("p50 {:.1f} us since the peer sent", s.data_age_sender_us.p50);
       return Lines{
           fmt::format("p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us since receive; {}; in cycles 0/1/2/3+: {}/{}/{}/{}",
                       s.data_age_us.p50, s.data_age_us.p99, s.data_age_us.max, sent, c[0], c[1], c[2], c[3])};
     }},
    {"realtime_settings_applied", [](const S& s) { return Json(s.realtime_settings_applied); }},
    {"cpu_dma_latency_held",
     [](const S& s) { return Json(s.cpu_dma_latency_held); },
     kEnd,
     "real-time",
     [](const S& s) {
       if (!s.realtime_settings_applied) return Lines{"NOT APPLIED: running without real-time settings (realtime.*)"};
       return Lines{fmt::format("SCHED_FIFO, memory locked{}", s.cpu_dma_latency_held ? ", cpu_dma_latency held" : "")};
     }},
    {"cycles_with_peer", [](const S& s) { return Json(s.cycles_with_peer); }},
    {"watchdog_trips",
     [](const S& s) { return Json(s.watchdog_trips); },
     false,
     "peer",
     [](const S& s) {
       return Lines{fmt::format("fresh in {} cycles, watchdog trips {}", s.cycles_with_peer, s.watchdog_trips)};
     }},
    {"device_fault_cycles", [](const S& s) { return Json(s.device_fault_cycles); }},
    {"nonfinite_inputs", [](const S& s) { return Json(s.nonfinite_inputs); }},
    {"saturated_cycles",
     [](const S& s) { return Json(s.saturated_cycles); },
     false,
     "faults",
     [](const S& s) {
       return Lines{fmt::format("device fault cycles {}, non-finite inputs {}, saturated cycles {}",
                                s.device_fault_cycles, s.nonfinite_inputs, s.saturated_cycles)};
     }},
    {"dof_mismatches", [](const S& s) { return Json(s.dof_mismatches); }, kEnd},
    {"tracking_error_rms_m", [](const S& s) { return Json(s.tracking_error_rms_m); }},
    {"tracking_error_max_m",
     [](const S& s) { return Json(s.tracking_error_max_m); },
     false,
     "tracking error",
     [](const S& s) {
       return Lines{
           fmt::format("rms {:.3f} mm, max {:.3f} mm", s.tracking_error_rms_m * 1e3, s.tracking_error_max_m * 1e3)};
     }},
    {"fixture_max_penetration_m",
     [](const S& s) { return Json(s.fixture_max_penetration_m); },
     kEnd,
     "fixture",
     [](const S& s) { return Lines{fmt::format("max penetration {:.3f} mm", s.fixture_max_penetration_m * 1e3)}; }},
    {"passivity",
     [](const S& s) { return Object(kPassivityFields, s); },
     kEnd,
     "passivity",
     [](const S& s) {
       std::string line =
           fmt::format("{}: controller acted in {} cycles, dissipated {:.6g} J, observed energy min {:.6g} J",
                       s.passivity_mode, s.passivity_cycles, s.passivity_dissipated_J, s.passivity_min_observed_J);
       if (s.passivity_peer_without_energy > 0) {
         line += fmt::format(", {} peer samples without energy", s.passivity_peer_without_energy);
       }
       return Lines{line};
     }},
    {"telemetry_records", [](const S& s) { return Json(s.telemetry_records); }},
    {"telemetry_dropped",
     [](const S& s) { return Json(s.telemetry_dropped); },
     kEnd,
     "telemetry",
     [](const S& s) { return Lines{fmt::format("{} records, {} dropped", s.telemetry_records, s.telemetry_dropped)}; }},
    {"device_warnings",
     [](const S& s) { return Object(kDeviceWarningFields, s.device_warnings); },
     kEnd,
     "device warnings",
     [](const S& s) {
       const auto& w = s.device_warnings;
       return Lines{
           fmt::format("{} changes, set in {} cycles, seen 0x{:x}, last 0x{:x}", w.changes, w.cycles, w.seen, w.last)};
     }},
    {"engagement",
     [](const S& s) { return Object(kEngagementFields, s.engagement); },
     kEnd,
     "engagement",
     [](const S& s) {
       const auto& e = s.engagement;
       return Lines{fmt::format(
           "engaged {} times ({} cycles), coupling lost {} times, now {}; aligning mean {:.1f} ms, max {:.1f} ms; max "
           "re-engagement step {:.4f} mm, max aligning force rate {:.1f} N/s",
           e.times_engaged, e.engaged_cycles, e.couplings_lost, e.final_state, e.aligning_mean_s * 1e3,
           e.aligning_max_s * 1e3, e.max_reference_step_m * 1e3, e.max_aligning_force_rate_N_per_s)};
     }},
    {"", nullptr, false, "safe state",
     [](const S& s) {
       const auto& e = s.engagement;
       return Lines{
           fmt::format("reaction '{}'; latency gate trips {}, new sessions {}; readings refused: {} non-finite, {} out "
                       "of range, {} "
                       "encoder jumps",
                       e.reaction, e.latency_gate_trips, e.new_sessions, e.nonfinite_readings, e.out_of_range_readings,
                       e.encoder_jumps)};
     }},
    {"faults",
     [](const S& s) { return FaultsJson(s.faults); },
     kEnd,
     "fault",
     [](const S& s) {
       Lines lines;
       for (const FaultReport& f : s.faults) {
         lines.push_back(
             fmt::format("{} at cycle {} (t = {:.3f} s, peer sample {:.1f} ms old){}: {}; record {}", ToString(f.kind),
                         f.cycle, f.time_s, f.peer_sample_age_s * 1e3,
                         f.device_faults != 0 ? fmt::format(" bits 0x{:x}", f.device_faults) : std::string(),
                         f.reaction, f.file.empty() ? std::string("not written") : f.file));
       }
       return lines;
     }},
    {"fault_records_skipped",
     [](const S& s) { return Json(s.fault_records_skipped); },
     kEnd,
     "fault records",
     [](const S& s) {
       if (s.fault_records_skipped == 0) return Lines{};
       return Lines{fmt::format("{} not written (writer busy or safety.max_fault_records)", s.fault_records_skipped)};
     }},
    {"clock", [](const S& s) { return Object(kClockFields, s); }, kEnd},
    {"telemetry_csv", [](const S& s) { return Json(s.telemetry_csv); }},
    {"config_path", [](const S& s) { return Json(s.config_path); }, kEnd},
    {"startup_analysis", [](const S& s) { return Json(s.startup_analysis); }, kEnd},
    {"config_yaml", [](const S& s) { return Json(s.config_yaml); }, kEnd},
});

}  // namespace

std::string FormatSummaryText(const RunSummary& s) {
  std::string out = fmt::format("teleop-{} summary ({})\n", ToString(s.role), s.stop_reason);
  for (const SummaryField& f : kSummaryFields) {
    if (f.text == nullptr) continue;
    for (const std::string& content : f.text(s)) out += fmt::format("  {:<18}{}\n", f.label, content);
  }
  return out;
}

std::string FormatSummaryJson(const RunSummary& s) {
  std::size_t last = 0;  // the last row with a key: no comma after it
  for (std::size_t i = 0; i < kSummaryFields.size(); ++i) {
    if (!kSummaryFields[i].key.empty()) last = i;
  }
  std::string out = "{\n";
  bool line_start = true;
  for (std::size_t i = 0; i <= last; ++i) {
    const SummaryField& f = kSummaryFields[i];
    if (f.key.empty()) continue;
    out += fmt::format(R"({}"{}": {})", line_start ? "  " : ", ", f.key, f.json(s));
    line_start = f.line_end;
    if (f.line_end) out += i < last ? ",\n" : "\n";
  }
  return out + "}\n";
}

}  // namespace teleop::node
