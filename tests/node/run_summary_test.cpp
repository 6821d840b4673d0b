// The run summary: its layout byte for byte (scripts and tests parse the JSON, people read the text), and its
// link_emulation field (link.emulate, docs/link-emulation.md): null without emulation, every counter by name with it,
// in the JSON and the text.
#include "teleop/node/run_summary.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace teleop::node {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// Every field of the summary set to a value of its own (one NaN, two faults, emulation on, psk with refusals), so
// that a field written under the wrong key, twice or not at all changes the output.
RunSummary Populated() {
  RunSummary s;
  s.role = Role::kSlave;
  s.software_version = "0.1.0+gabc1234";
  s.protocol_version = 2;
  s.connection = "connected";
  s.link_transport = "udp";
  s.rate_hz = 1000.0;
  s.duration_s = 2.5;
  s.cycles = 2497;
  s.achieved_rate_hz = 998.8;
  s.overruns = 3;
  s.period_us = Distribution{2497, 1000.1, 1012.5, 1100.25};
  s.jitter_us = Distribution{2497, 1.5, 12.25, 100.5};
  s.compute_us = Distribution{2497, 20.5, 40.25, 80.125};
  auto& l = s.link;
  l.sent = 2490;
  l.send_errors = 1;
  l.received = 2480;
  l.accepted = 2470;
  l.lost = 4;
  l.reordered = 2;
  l.duplicates = 5;
  l.rejected = 6;
  l.rejected_by_reason[1] = 7;
  l.rejected_by_reason[2] = 8;
  l.wrong_sender = 9;
  l.superseded = 10;
  l.bus_errors = 11;
  l.secure_rejected_by_reason[static_cast<std::size_t>(transport::SecureReceiveStatus::kBadTag)] = 12;
  l.secure_rejected_by_reason[static_cast<std::size_t>(transport::SecureReceiveStatus::kBadPlaintext)] = 13;
  l.handshake_messages = 14;
  l.sessions = 2;
  l.handshakes_started = 15;
  l.send_no_session = 16;
  s.link_security = "psk";
  s.link_detail = "frames 100";
  s.link_fault_cycles = 17;
  transport::ImpairmentCounters c;
  c.offered = 1000;
  c.delivered = 990;
  c.dropped_loss = 18;
  s.link_emulation = c;
  s.rtt_ms = Distribution{2400, 0.125, 0.5, 1.75};
  s.sync = "triggered";
  s.triggered_cycles = 2400;
  s.trigger_timeouts = 19;
  s.trigger_timeouts_coupled = 20;
  s.data_age_us = Distribution{2470, 30.5, 60.25, 90.125};
  s.data_age_sender_us = Distribution{2470, 40.5, 70.25, 95.125};
  s.data_age_cycles = {2000, 400, 50, 20};
  s.realtime_settings_applied = true;
  s.cpu_dma_latency_held = true;
  s.cycles_with_peer = 2460;
  s.watchdog_trips = 21;
  s.dof_mismatches = 22;
  s.device_fault_cycles = 23;
  s.nonfinite_inputs = 24;
  s.saturated_cycles = 25;
  s.tracking_error_rms_m = 0.00125;
  s.tracking_error_max_m = std::nan("");
  s.fixture_max_penetration_m = 0.0025;
  s.telemetry_records = 2497;
  s.telemetry_dropped = 26;
  s.stop_reason = "peer shutdown";
  s.passivity_mode = "observer";
  s.passivity_cycles = 27;
  s.passivity_dissipated_J = 0.015625;
  s.passivity_min_observed_J = -0.25;
  s.passivity_peer_without_energy = 28;
  auto& e = s.engagement;
  e.reaction = "hold";
  e.final_state = "engaged";
  e.times_engaged = 29;
  e.couplings_lost = 30;
  e.engaged_cycles = 2300;
  e.aligning_mean_s = 0.0125;
  e.aligning_max_s = 0.025;
  e.max_reference_step_m = 0.0005;
  e.max_aligning_force_rate_N_per_s = 12.5;
  e.latency_gate_trips = 31;
  e.new_sessions = 32;
  e.encoder_jumps = 33;
  e.out_of_range_readings = 34;
  e.nonfinite_readings = 35;
  s.device_warnings = DeviceWarningSummary{36, 37, 0x5, 0x7};
  FaultReport f1;
  f1.kind = Outage::kPeerLost;
  f1.cycle = 1000;
  f1.time_s = 1.0;
  f1.reaction = "hold";
  f1.peer_sample_age_s = 0.0625;
  f1.file = "fault-1.csv";
  FaultReport f2;
  f2.kind = Outage::kDeviceFault;
  f2.cycle = 2000;
  f2.time_s = 2.0;
  f2.reaction = "device safe state";
  f2.peer_sample_age_s = std::nan("");
  f2.device_faults = 0x10;
  s.faults = {f1, f2};
  s.fault_records_skipped = 38;
  s.clock_start_monotonic_ns = 123456789;
  s.peer_clock_offset_ns = -2500;
  s.peer_clock_offset_uncertainty_ns = 40000;
  s.telemetry_csv = "slave.csv";
  s.config_path = "/etc/teleop/slave.yaml";
  s.startup_analysis = "stability check passed";
  s.config_yaml = "role: slave\n";
  return s;
}

// The layout of every field (written by the tables of run_summary.cpp): the key of each value, the line breaks, null
// for NaN, the fault list one per line. Taken from the output before the tables replaced the format strings.
TEST(RunSummary, JsonLayoutOfEveryField) {
  EXPECT_EQ(FormatSummaryJson(Populated()), R"json({
  "role": "slave", "software_version": "0.1.0+gabc1234", "protocol_version": 2,
  "stop_reason": "peer shutdown", "connected": true, "connection": "connected",
  "rate_hz": 1000, "duration_s": 2.5, "cycles": 2497, "achieved_rate_hz": 998.8, "overruns": 3,
  "period_us": {"count": 2497, "p50": 1000.1, "p99": 1012.5, "max": 1100.25}, "jitter_us": {"count": 2497, "p50": 1.5, "p99": 12.25, "max": 100.5}, "compute_us": {"count": 2497, "p50": 20.5, "p99": 40.25, "max": 80.125},
  "packets": {"sent": 2490, "send_errors": 1, "received": 2480, "accepted": 2470, "lost": 4, "reordered": 2, "duplicates": 5, "rejected": 6, "wrong_sender": 9, "superseded": 10, "bus_errors": 11, "rejected_by_reason": {"too_short": 7, "bad_magic": 8, "bad_version": 0, "bad_type": 0, "bad_dof": 0, "bad_length": 0, "bad_crc": 0, "non_finite": 0, "out_of_range": 0}},
  "security": {"mode": "psk", "sessions": 2, "handshakes_started": 15, "handshake_messages": 14, "send_no_session": 16, "rejected_by_reason": {"rate_limited": 0, "handshake_rate_limited": 0, "insecure": 0, "malformed": 0, "wrong_sender": 0, "unexpected_handshake": 0, "bad_handshake_tag": 0, "no_session": 0, "wrong_session": 0, "replayed": 0, "too_old": 0, "bad_tag": 12, "bad_plaintext": 13, "implausible": 0, "stale_handshake": 0}},
  "link_transport": "udp", "link_detail": "frames 100", "link_fault_cycles": 17,
  "link_emulation": {"offered": 1000, "delivered": 990, "dropped_loss": 18, "dropped_burst": 0, "dropped_outage": 0, "dropped_bandwidth": 0, "dropped_overflow": 0, "duplicated": 0, "copies_refused": 0, "reordered": 0, "corrupted": 0, "delayed": 0},
  "rtt_ms": {"count": 2400, "p50": 0.125, "p99": 0.5, "max": 1.75},
  "sync": "triggered", "triggered_cycles": 2400, "trigger_timeouts": 19, "trigger_timeouts_coupled": 20,
  "data_age_us": {"count": 2470, "p50": 30.5, "p99": 60.25, "max": 90.125}, "data_age_sender_us": {"count": 2470, "p50": 40.5, "p99": 70.25, "max": 95.125}, "data_age_cycles": [2000, 400, 50, 20],
  "realtime_settings_applied": true, "cpu_dma_latency_held": true,
  "cycles_with_peer": 2460, "watchdog_trips": 21, "device_fault_cycles": 23, "nonfinite_inputs": 24, "saturated_cycles": 25, "dof_mismatches": 22,
  "tracking_error_rms_m": 0.00125, "tracking_error_max_m": null, "fixture_max_penetration_m": 0.0025,
  "passivity": {"mode": "observer", "cycles": 27, "dissipated_J": 0.015625, "min_observed_J": -0.25, "peer_without_energy": 28},
  "telemetry_records": 2497, "telemetry_dropped": 26,
  "device_warnings": {"changes": 36, "cycles": 37, "seen": 7, "last": 5},
  "engagement": {"reaction": "hold", "final_state": "engaged", "times_engaged": 29, "couplings_lost": 30, "engaged_cycles": 2300, "aligning_mean_s": 0.0125, "aligning_max_s": 0.025, "max_reengagement_step_m": 0.0005, "max_aligning_force_rate_N_per_s": 12.5, "latency_gate_trips": 31, "new_sessions": 32, "encoder_jumps": 33, "out_of_range_readings": 34, "nonfinite_readings": 35},
  "faults": [
    {"kind": "peer lost", "cycle": 1000, "time_s": 1, "reaction": "hold", "peer_sample_age_s": 0.0625, "device_faults": 0, "record": "fault-1.csv"},
    {"kind": "device fault", "cycle": 2000, "time_s": 2, "reaction": "device safe state", "peer_sample_age_s": null, "device_faults": 16, "record": ""}
  ],
  "fault_records_skipped": 38,
  "clock": {"start_monotonic_ns": 123456789, "peer_offset_ns": -2500, "peer_offset_uncertainty_ns": 40000},
  "telemetry_csv": "slave.csv", "config_path": "/etc/teleop/slave.yaml",
  "startup_analysis": "stability check passed",
  "config_yaml": "role: slave\n"
}
)json");
}

// The text follows the one field table's order, which is the JSON's: "link faults" before "link emulation", "sync"
// before "data age", and the "faults" line right after "peer" (the fields of one JSON line), since the text and the
// JSON came from one table (they were two tables in two orders before).
TEST(RunSummary, TextOfEveryField) {
  EXPECT_EQ(FormatSummaryText(Populated()), R"text(teleop-slave summary (peer shutdown)
  version           0.1.0+gabc1234, wire protocol 2
  connection        connected
  cycles            2497 in 2.500 s (998.8 Hz achieved, 1000 Hz configured), overruns 3
  period jitter     p50 1.5 us, p99 12.2 us, max 100.5 us
  compute time      p50 20.5 us, p99 40.2 us, max 80.1 us
  packets           sent 2490, received 2480, accepted 2470, superseded 10, lost 4, reordered 2, duplicates 5, rejected 6, send errors 1
  security          psk: sessions 2, handshakes started 15, handshake messages 14, unsent (no session) 16; refused: bad_tag 12, bad_plaintext 13 (bad_plaintext: authentic samples of another DOF count or role; check both configs' dof)
  link detail       frames 100
  link faults       medium down in 17 cycles
  link emulation    offered 1000, delivered 990, dropped loss/burst/outage/bandwidth/overflow 18/0/0/0/0, duplicated 0, reordered 0, corrupted 0, delayed 0
  round trip        p50 0.125 ms, p99 0.500 ms, max 1.750 ms (2400 samples)
  sync              triggered, 2400 cycles triggered by the peer's sample, 19 timeouts (20 while coupled)
  data age          p50 30.5 us, p99 60.2 us, max 90.1 us since receive; p50 40.5 us since the peer sent; in cycles 0/1/2/3+: 2000/400/50/20
  real-time         SCHED_FIFO, memory locked, cpu_dma_latency held
  peer              fresh in 2460 cycles, watchdog trips 21
  faults            device fault cycles 23, non-finite inputs 24, saturated cycles 25
  tracking error    rms 1.250 mm, max nan mm
  fixture           max penetration 2.500 mm
  passivity         observer: controller acted in 27 cycles, dissipated 0.015625 J, observed energy min -0.25 J, 28 peer samples without energy
  telemetry         2497 records, 26 dropped
  device warnings   36 changes, set in 37 cycles, seen 0x7, last 0x5
  engagement        engaged 29 times (2300 cycles), coupling lost 30 times, now engaged; aligning mean 12.5 ms, max 25.0 ms; max re-engagement step 0.5000 mm, max aligning force rate 12.5 N/s
  safe state        reaction 'hold'; latency gate trips 31, new sessions 32; readings refused: 35 non-finite, 34 out of range, 33 encoder jumps
  fault             peer lost at cycle 1000 (t = 1.000 s, peer sample 62.5 ms old): hold; record fault-1.csv
  fault             device fault at cycle 2000 (t = 2.000 s, peer sample nan ms old) bits 0x10: device safe state; record not written
  fault records     38 not written (writer busy or safety.max_fault_records)
)text");
}

// The round-trip line says why there is none, per transport: CAN frames carry no timestamps; a UDP peer that never
// answered; a UDP peer whose samples never echoed one of ours.
TEST(RunSummary, RoundTripNotMeasuredSaysWhyPerTransport) {
  RunSummary s;
  s.link_transport = "emulated-can";
  EXPECT_THAT(FormatSummaryText(s), HasSubstr("round trip        not measured (emulated-can: CAN frames carry no"));
  s.link_transport = "udp";
  s.connected = false;
  EXPECT_THAT(FormatSummaryText(s), HasSubstr("round trip        not measured (the peer never answered)\n"));
  EXPECT_THAT(FormatSummaryText(s), Not(HasSubstr("CAN")));
  s.connected = true;
  EXPECT_THAT(FormatSummaryText(s), HasSubstr("not measured (no sample of the peer echoed one of ours)"));
}

// Over CAN there is no round trip, so no clock offset and no age since the peer sent: the line says so instead of
// "p50 0.0 us" (demo.sh --can printed that).
TEST(RunSummary, DataAgeSinceThePeerSentNotMeasuredWithoutARoundTrip) {
  RunSummary s;
  s.link_transport = "emulated-can";
  s.data_age_us = Distribution{100, 315.0, 4928.0, 14328.6};
  EXPECT_THAT(FormatSummaryText(s), HasSubstr("since receive; since the peer sent not measured (no round trip);"));
  EXPECT_THAT(FormatSummaryText(s), Not(HasSubstr("us since the peer sent")));
}

TEST(RunSummary, LinkEmulationIsNullWithoutEmulation) {
  const RunSummary s;
  EXPECT_THAT(FormatSummaryJson(s), HasSubstr("\"link_emulation\": null,"));
  EXPECT_THAT(FormatSummaryText(s), Not(HasSubstr("link emulation")));
}

TEST(RunSummary, LinkEmulationCountersAreReportedByName) {
  RunSummary s;
  transport::ImpairmentCounters c;
  c.offered = 1000;
  c.delivered = 990;
  c.dropped_loss = 11;
  c.dropped_burst = 12;
  c.dropped_outage = 13;
  c.dropped_bandwidth = 14;
  c.dropped_overflow = 15;
  c.duplicated = 16;
  c.copies_refused = 17;
  c.reordered = 18;
  c.corrupted = 19;
  c.delayed = 20;
  s.link_emulation = c;
  EXPECT_THAT(FormatSummaryJson(s),
              HasSubstr("\"link_emulation\": {\"offered\": 1000, \"delivered\": 990, \"dropped_loss\": 11, "
                        "\"dropped_burst\": 12, \"dropped_outage\": 13, \"dropped_bandwidth\": 14, "
                        "\"dropped_overflow\": 15, \"duplicated\": 16, \"copies_refused\": 17, \"reordered\": 18, "
                        "\"corrupted\": 19, \"delayed\": 20},"));
  EXPECT_THAT(FormatSummaryText(s),
              HasSubstr("  link emulation    offered 1000, delivered 990, dropped loss/burst/outage/bandwidth/overflow "
                        "11/12/13/14/15, duplicated 16, reordered 18, corrupted 19, delayed 20\n"));
}

}  // namespace
}  // namespace teleop::node
