#include "teleop/node/run_summary.hpp"

#include <fmt/format.h>

#include <cmath>
#include <string>

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

std::string DistJson(const Distribution& d) {
  return fmt::format(R"({{"count": {}, "p50": {}, "p99": {}, "max": {}}})", d.count, Num(d.p50), Num(d.p99),
                     Num(d.max));
}

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

}  // namespace

std::string FormatSummaryText(const RunSummary& s) {
  const auto& l = s.link;
  std::string out;
  out += fmt::format("teleop-{} summary ({})\n", ToString(s.role), s.stop_reason);
  out += fmt::format("  cycles            {} in {:.3f} s ({:.1f} Hz achieved, {:.0f} Hz configured), overruns {}\n",
                     s.cycles, s.duration_s, s.achieved_rate_hz, s.rate_hz, s.overruns);
  out += fmt::format("  period jitter     p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us\n", s.jitter_us.p50,
                     s.jitter_us.p99, s.jitter_us.max);
  out += fmt::format("  compute time      p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us\n", s.compute_us.p50,
                     s.compute_us.p99, s.compute_us.max);
  out += fmt::format(
      "  packets           sent {}, received {}, accepted {}, lost {}, reordered {}, duplicates {}, "
      "rejected {}, send errors {}\n",
      l.sent, l.received, l.accepted, l.lost, l.reordered, l.duplicates, l.rejected, l.send_errors);
  out += fmt::format("  security          {}\n", SecurityText(s));
  if (!s.link_detail.empty()) out += fmt::format("  link detail       {}\n", s.link_detail);
  if (s.link_emulation) {
    out += fmt::format("  link emulation    {}\n", transport::FormatImpairmentCounters(*s.link_emulation));
  }
  if (s.link_fault_cycles > 0)
    out += fmt::format("  link faults       medium down in {} cycles\n", s.link_fault_cycles);
  if (s.rtt_ms.count > 0) {
    out += fmt::format("  round trip        p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms ({} samples)\n", s.rtt_ms.p50,
                       s.rtt_ms.p99, s.rtt_ms.max, s.rtt_ms.count);
  } else {
    out += "  round trip        not measured (no echo from the peer; CAN frames carry no timestamps)\n";
  }
  if (s.data_age_us.count > 0) {
    const auto& c = s.data_age_cycles;
    out += fmt::format(
        "  data age          p50 {:.1f} us, p99 {:.1f} us, max {:.1f} us since receive; p50 {:.1f} us since the peer "
        "sent; in cycles 0/1/2/3+: {}/{}/{}/{}\n",
        s.data_age_us.p50, s.data_age_us.p99, s.data_age_us.max, s.data_age_sender_us.p50, c[0], c[1], c[2], c[3]);
  }
  out += fmt::format("  sync              {}", s.sync);
  if (s.triggered_cycles + s.trigger_timeouts > 0) {
    out += fmt::format(", {} cycles triggered by the peer's sample, {} timeouts ({} while coupled)", s.triggered_cycles,
                       s.trigger_timeouts, s.trigger_timeouts_coupled);
  }
  out += "\n";
  out += s.realtime_settings_applied
             ? fmt::format("  real-time         SCHED_FIFO, memory locked{}\n",
                           s.cpu_dma_latency_held ? ", cpu_dma_latency held" : "")
             : std::string("  real-time         NOT APPLIED: running without real-time settings (realtime.*)\n");
  out +=
      fmt::format("  peer              fresh in {} cycles, watchdog trips {}\n", s.cycles_with_peer, s.watchdog_trips);
  out += fmt::format("  tracking error    rms {:.3f} mm, max {:.3f} mm\n", s.tracking_error_rms_m * 1e3,
                     s.tracking_error_max_m * 1e3);
  out += fmt::format("  fixture           max penetration {:.3f} mm\n", s.fixture_max_penetration_m * 1e3);
  out += fmt::format("  faults            device fault cycles {}, non-finite inputs {}, saturated cycles {}\n",
                     s.device_fault_cycles, s.nonfinite_inputs, s.saturated_cycles);
  out += fmt::format(
      "  passivity         {}: controller acted in {} cycles, dissipated {:.6g} J, observed energy min "
      "{:.6g} J",
      s.passivity_mode, s.passivity_cycles, s.passivity_dissipated_J, s.passivity_min_observed_J);
  if (s.passivity_peer_without_energy > 0) {
    out += fmt::format(", {} peer samples without energy", s.passivity_peer_without_energy);
  }
  out += "\n";
  out += fmt::format("  telemetry         {} records, {} dropped\n", s.telemetry_records, s.telemetry_dropped);
  const auto& w = s.device_warnings;
  out += fmt::format("  device warnings   {} changes, set in {} cycles, seen 0x{:x}, last 0x{:x}\n", w.changes,
                     w.cycles, w.seen, w.last);
  const auto& e = s.engagement;
  out += fmt::format(
      "  engagement        engaged {} times ({} cycles), coupling lost {} times, now {}; aligning mean {:.1f} ms, "
      "max {:.1f} ms; max re-engagement step {:.4f} mm, max aligning force rate {:.1f} N/s\n",
      e.times_engaged, e.engaged_cycles, e.couplings_lost, e.final_state, e.aligning_mean_s * 1e3,
      e.aligning_max_s * 1e3, e.max_reference_step_m * 1e3, e.max_aligning_force_rate_N_per_s);
  out += fmt::format(
      "  safe state        reaction '{}'; latency gate trips {}, new sessions {}; readings refused: "
      "{} non-finite, {} out of range, {} encoder jumps\n",
      e.reaction, e.latency_gate_trips, e.new_sessions, e.nonfinite_readings, e.out_of_range_readings, e.encoder_jumps);
  for (const FaultReport& f : s.faults) {
    out +=
        fmt::format("  fault             {} at cycle {} (t = {:.3f} s, peer sample {:.1f} ms old){}: {}; record {}\n",
                    ToString(f.kind), f.cycle, f.time_s, f.peer_sample_age_s * 1e3,
                    f.device_faults != 0 ? fmt::format(" bits 0x{:x}", f.device_faults) : std::string(), f.reaction,
                    f.file.empty() ? std::string("not written") : f.file);
  }
  if (s.fault_records_skipped > 0) {
    out += fmt::format("  fault records     {} not written (writer busy or safety.max_fault_records)\n",
                       s.fault_records_skipped);
  }
  return out;
}

std::string FormatSummaryJson(const RunSummary& s) {
  const auto& l = s.link;
  std::string out = "{\n";
  out += fmt::format(R"(  "role": {},)"
                     "\n",
                     JsonString(ToString(s.role)));
  out += fmt::format(R"(  "stop_reason": {},)"
                     "\n",
                     JsonString(s.stop_reason));
  out += fmt::format(R"(  "rate_hz": {}, "duration_s": {}, "cycles": {}, "achieved_rate_hz": {}, "overruns": {},)"
                     "\n",
                     Num(s.rate_hz), Num(s.duration_s), s.cycles, Num(s.achieved_rate_hz), s.overruns);
  out += fmt::format(R"(  "period_us": {}, "jitter_us": {}, "compute_us": {},)"
                     "\n",
                     DistJson(s.period_us), DistJson(s.jitter_us), DistJson(s.compute_us));
  out += fmt::format(R"(  "packets": {{"sent": {}, "send_errors": {}, "received": {}, "accepted": {}, "lost": {}, )"
                     R"("reordered": {}, "duplicates": {}, "rejected": {}, "wrong_sender": {}, "superseded": {}, )"
                     R"("bus_errors": {}, "rejected_by_reason": {}}},)"
                     "\n",
                     l.sent, l.send_errors, l.received, l.accepted, l.lost, l.reordered, l.duplicates, l.rejected,
                     l.wrong_sender, l.superseded, l.bus_errors, RejectedJson(l));
  out +=
      fmt::format(R"(  "security": {{"mode": {}, "sessions": {}, "handshakes_started": {}, "handshake_messages": {}, )"
                  R"("send_no_session": {}, "rejected_by_reason": {}}},)"
                  "\n",
                  JsonString(s.link_security), l.sessions, l.handshakes_started, l.handshake_messages,
                  l.send_no_session, SecureRejectedJson(l));
  out += fmt::format(R"(  "link_detail": {}, "link_fault_cycles": {},)"
                     "\n",
                     JsonString(s.link_detail), s.link_fault_cycles);
  out += fmt::format(R"(  "link_emulation": {},)"
                     "\n",
                     s.link_emulation ? transport::ImpairmentCountersJson(*s.link_emulation) : std::string("null"));
  out += fmt::format(R"(  "rtt_ms": {},)"
                     "\n",
                     DistJson(s.rtt_ms));
  out += fmt::format(R"(  "sync": {}, "triggered_cycles": {}, "trigger_timeouts": {}, "trigger_timeouts_coupled": {},)"
                     "\n",
                     JsonString(s.sync), s.triggered_cycles, s.trigger_timeouts, s.trigger_timeouts_coupled);
  out += fmt::format(R"(  "data_age_us": {}, "data_age_sender_us": {}, "data_age_cycles": [{}, {}, {}, {}],)"
                     "\n",
                     DistJson(s.data_age_us), DistJson(s.data_age_sender_us), s.data_age_cycles[0],
                     s.data_age_cycles[1], s.data_age_cycles[2], s.data_age_cycles[3]);
  out += fmt::format(R"(  "realtime_settings_applied": {}, "cpu_dma_latency_held": {},)"
                     "\n",
                     s.realtime_settings_applied, s.cpu_dma_latency_held);
  out += fmt::format(R"(  "cycles_with_peer": {}, "watchdog_trips": {}, "device_fault_cycles": {}, )"
                     R"("nonfinite_inputs": {}, "saturated_cycles": {}, "dof_mismatches": {},)"
                     "\n",
                     s.cycles_with_peer, s.watchdog_trips, s.device_fault_cycles, s.nonfinite_inputs,
                     s.saturated_cycles, s.dof_mismatches);
  out += fmt::format(R"(  "tracking_error_rms_m": {}, "tracking_error_max_m": {}, "fixture_max_penetration_m": {},)"
                     "\n",
                     Num(s.tracking_error_rms_m), Num(s.tracking_error_max_m), Num(s.fixture_max_penetration_m));
  out += fmt::format(R"(  "passivity": {{"mode": {}, "cycles": {}, "dissipated_J": {}, "min_observed_J": {}, )"
                     R"("peer_without_energy": {}}},)"
                     "\n",
                     JsonString(s.passivity_mode), s.passivity_cycles, Num(s.passivity_dissipated_J),
                     Num(s.passivity_min_observed_J), s.passivity_peer_without_energy);
  out += fmt::format(R"(  "telemetry_records": {}, "telemetry_dropped": {},)"
                     "\n",
                     s.telemetry_records, s.telemetry_dropped);
  out +=
      fmt::format(R"(  "device_warnings": {{"changes": {}, "cycles": {}, "seen": {}, "last": {}}},)"
                  "\n",
                  s.device_warnings.changes, s.device_warnings.cycles, s.device_warnings.seen, s.device_warnings.last);
  const auto& e = s.engagement;
  out += fmt::format(
      R"(  "engagement": {{"reaction": {}, "final_state": {}, "times_engaged": {}, "couplings_lost": {}, )"
      R"("engaged_cycles": {}, "aligning_mean_s": {}, "aligning_max_s": {}, "max_reengagement_step_m": {}, )"
      R"("max_aligning_force_rate_N_per_s": {}, "latency_gate_trips": {}, "new_sessions": {}, "encoder_jumps": {}, )"
      R"("out_of_range_readings": {}, "nonfinite_readings": {}}},)"
      "\n",
      JsonString(e.reaction), JsonString(e.final_state), e.times_engaged, e.couplings_lost, e.engaged_cycles,
      Num(e.aligning_mean_s), Num(e.aligning_max_s), Num(e.max_reference_step_m),
      Num(e.max_aligning_force_rate_N_per_s), e.latency_gate_trips, e.new_sessions, e.encoder_jumps,
      e.out_of_range_readings, e.nonfinite_readings);
  out += R"(  "faults": [)";
  for (std::size_t i = 0; i < s.faults.size(); ++i) {
    const FaultReport& f = s.faults[i];
    out += fmt::format(R"({}{{"kind": {}, "cycle": {}, "time_s": {}, "reaction": {}, "peer_sample_age_s": {}, )"
                       R"("device_faults": {}, "record": {}}})",
                       i == 0 ? "\n    " : ",\n    ", JsonString(ToString(f.kind)), f.cycle, Num(f.time_s),
                       JsonString(f.reaction), Num(f.peer_sample_age_s), f.device_faults, JsonString(f.file));
  }
  out += fmt::format(R"({}],)"
                     "\n",
                     s.faults.empty() ? "" : "\n  ");
  out += fmt::format(R"(  "fault_records_skipped": {})"
                     "\n}}\n",
                     s.fault_records_skipped);
  return out;
}

}  // namespace teleop::node
