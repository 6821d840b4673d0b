// Cuts of the link and device faults between two TeleopNodes with loopback plants (the master pushed by a scripted
// operator, the slave with its forbidden-region fixture), joined by an emulated link and stepped in lock-step on a
// simulated clock: deterministic. For each cut: the time from the last packet to the safe state, the slave's
// excursion while cut off, the step at re-engagement. For each device fault: the safe state and its record.
// The tables are printed (the numbers the report quotes); the targets are asserted.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/device/loopback.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::node {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr int kTimeoutCycles = 50;  // link.timeout_ms below

std::string FaultDir() {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "node_cut_test";
  std::filesystem::create_directories(dir);
  return dir.string();
}

// The demo's gains and plants; the operator moves the master sinusoidally (about ±15 mm at 0.4 Hz: up to ~38 mm/s).
/// `tail`: more top-level YAML (e.g. an engagement: section); `safety`: more keys of the safety: mapping.
std::string MasterConfig(const std::string& tail = "", const std::string& safety = "") {
  return R"(role: master
dof: 1
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47001", peer: "127.0.0.1:47002", timeout_ms: 50}
law: {kp_N_per_m: 600, kd_Ns_per_m: 2, max_force_N: 10, velocity_filter_hz: 200}
device:
  backend: loopback
  loopback:
    mass_kg: 0.040
    damping_Ns_per_m: 0.41
    operator:
      mass_kg: 0.01
      damping_Ns_per_m: 2
      stiffness_N_per_m: 200
      script:
        - {type: sine, axis: 0, start_s: 0, amplitude_N: 3, frequency_hz: 0.4}
stability: {check: false}
safety: {fault_record_dir: ")" +
         FaultDir() + "\"" + safety + "}\n" + tail;
}

std::string SlaveConfig(const std::string& tail = "", const std::string& safety = "") {
  return R"(role: slave
dof: 1
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47002", peer: "127.0.0.1:47001", timeout_ms: 50}
law: {kp_N_per_m: 600, kd_Ns_per_m: 2, max_force_N: 10, velocity_filter_hz: 200}
fixture: {stiffness_N_per_m: 2000, half_space: {axis: 0, offset_m: 0.01, direction: +1}}
device: {backend: loopback, loopback: {mass_kg: 0.036, damping_Ns_per_m: 0.49}}
stability: {check: false}
safety: {fault_record_dir: ")" +
         FaultDir() + "\"" + safety + "}\n" + tail;
}

/// A link that drops everything sent while `cut` is set (both directions are cut by cutting both ends).
class CuttableLink final : public transport::Link {
 public:
  CuttableLink(std::unique_ptr<transport::Link> inner, const bool* cut) : inner_(std::move(inner)), cut_(cut) {}
  bool Send(const proto::SampleMessage& message) noexcept override { return *cut_ ? true : inner_->Send(message); }
  bool Poll(proto::SampleMessage& newest) noexcept override { return inner_->Poll(newest); }
  const transport::LinkCounters& counters() const noexcept override { return inner_->counters(); }
  std::string Describe() const override { return "cuttable " + inner_->Describe(); }
  std::uint64_t session_epoch() const noexcept override { return epoch; }
  std::uint64_t epoch = 0;  ///< What an authenticated link reports; the test bumps it for a "new session".

 private:
  std::unique_ptr<transport::Link> inner_;
  const bool* cut_;
};

/// A device in front of the loopback plant whose readings the test corrupts (NaN, offsets, fault bits).
class FaultyDevice final : public device::Device {
 public:
  explicit FaultyDevice(std::unique_ptr<device::Device> inner) : inner_(std::move(inner)) {}
  const device::Capabilities& capabilities() const noexcept override { return inner_->capabilities(); }
  const std::string& name() const noexcept override { return inner_->name(); }
  void Configure() override { inner_->Configure(); }
  void Activate() override { inner_->Activate(); }
  void Deactivate() noexcept override { inner_->Deactivate(); }
  void Read(device::Reading& out) noexcept override {
    inner_->Read(out);
    out.position_m[0] += position_offset_m;
    if (nan_position) out.position_m[0] = std::numeric_limits<double>::quiet_NaN();
    out.faults |= fault_bits;
  }
  void Write(const device::Command& command) noexcept override { inner_->Write(command); }
  void Update(double period_s) noexcept override { inner_->Update(period_s); }
  void SetSafe() noexcept override {
    ++safe_calls;
    inner_->SetSafe();
  }
  double position_offset_m = 0.0;
  bool nan_position = false;
  std::uint32_t fault_bits = 0;
  std::uint64_t safe_calls = 0;

 private:
  std::unique_ptr<device::Device> inner_;
};

struct Rig {
  explicit Rig(const std::string& tail = "", const std::string& master_safety = "",
               const std::string& slave_safety = "", const std::string& slave_tail = "") {
    medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
    const config::ProcessConfig mc = config::ParseProcessConfig(MasterConfig(tail, master_safety), "master.yaml");
    const config::ProcessConfig sc =
        config::ParseProcessConfig(SlaveConfig(tail + slave_tail, slave_safety), "slave.yaml");
    auto md = device::MakeDevice(mc.device);
    auto sd = device::MakeDevice(sc.device);
    master_plant = dynamic_cast<device::LoopbackPlant*>(md.get());
    slave_plant = dynamic_cast<device::LoopbackPlant*>(sd.get());
    auto faulty = std::make_unique<FaultyDevice>(std::move(sd));
    slave_device = faulty.get();
    auto ml = std::make_unique<CuttableLink>(
        std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster), &cut);
    auto sl = std::make_unique<CuttableLink>(
        std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave), &cut);
    slave_link = sl.get();
    master = std::make_unique<TeleopNode>(mc, std::move(md), std::move(ml));
    slave = std::make_unique<TeleopNode>(sc, std::move(faulty), std::move(sl));
  }
  void Step() {
    const std::int64_t now_ns = 1'000'000'000 + static_cast<std::int64_t>(cycle) * 1'000'000;
    master->Step(cycle, kPeriod_s, now_ns);
    slave->Step(cycle, kPeriod_s, now_ns);
    medium->Advance(kPeriod_s);
    ++cycle;
  }
  double slave_x() const { return slave_plant->true_position_m()[0]; }
  double master_x() const { return master_plant->true_position_m()[0]; }

  bool cut = false;
  std::shared_ptr<transport::EmulatedMedium> medium;
  device::LoopbackPlant* master_plant = nullptr;
  device::LoopbackPlant* slave_plant = nullptr;
  FaultyDevice* slave_device = nullptr;
  CuttableLink* slave_link = nullptr;
  std::unique_ptr<TeleopNode> master;
  std::unique_ptr<TeleopNode> slave;
  std::uint64_t cycle = 0;
};

struct CutResult {
  int cut_ms = 0;
  int safe_after_cycles = -1;  ///< From the slave's last received packet to its first non-engaged cycle; -1: none.
  int master_safe_after_cycles = -1;
  double excursion_m = 0.0;       ///< Slave: max |x - x(cut)| until aligning starts (or the cut ends + 1 s).
  double reengage_step_m = 0.0;   ///< Slave: max one-cycle |Δx| from the cut's end until engaged + 100 ms.
  double reference_step_m = 0.0;  ///< Slave summary: max one-cycle jump of the coupling reference.
  double force_rate_N_per_s = 0;  ///< Slave summary: max coupling-force rate while aligning.
  double aligning_ms = 0.0;       ///< Slave: aligning after the cut.
  double master_travel_m = 0.0;   ///< The master's motion during the cut.
  bool reengaged = false;
  std::uint64_t slave_fault_records = 0;
  std::string record;
};

CutResult RunCut(int cut_ms, double cut_at_s = 1.0, const std::string& tail = "", const std::string& master_safety = "",
                 const std::string& slave_safety = "") {
  Rig rig(tail, master_safety, slave_safety);
  CutResult r;
  r.cut_ms = cut_ms;
  const auto cut_start = static_cast<std::uint64_t>(std::lround(cut_at_s / kPeriod_s));
  const std::uint64_t cut_end = cut_start + static_cast<std::uint64_t>(cut_ms);
  while (rig.cycle < cut_start) rig.Step();
  EXPECT_EQ(rig.slave->engagement(), EngagementState::kEngaged) << "engaged before the cut";
  const double x_cut = rig.slave_x();
  if (std::getenv("CUT_TRACE") != nullptr) std::printf("cut at x_s %.6f x_m %.6f\n", x_cut, rig.master_x());
  const double m_cut = rig.master_x();
  rig.cut = true;
  bool aligning_seen = false;
  std::uint64_t aligning_from = 0;
  std::uint64_t engaged_at = 0;
  double prev = rig.slave_x();
  const std::uint64_t last_packet = cut_start - 1;  // the slave received the master's sample of this cycle
  for (std::uint64_t end = cut_end + 2000; rig.cycle < end;) {
    if (rig.cycle == cut_end) {
      rig.cut = false;
      r.master_travel_m = std::abs(rig.master_x() - m_cut);
    }
    const std::uint64_t k = rig.cycle;
    rig.Step();
    const double x = rig.slave_x();
    const EngagementState s = rig.slave->engagement();
    if (std::getenv("CUT_TRACE") != nullptr && k < cut_start + 80) {
      std::printf("  %llu x_s %.6f x_m %.6f state %d\n", static_cast<unsigned long long>(k), x, rig.master_x(),
                  static_cast<int>(s));
    }
    if (r.safe_after_cycles < 0 && s != EngagementState::kEngaged && k < cut_end + 5) {
      r.safe_after_cycles = static_cast<int>(k - last_packet);
    }
    if (r.master_safe_after_cycles < 0 && rig.master->engagement() != EngagementState::kEngaged && k < cut_end + 5) {
      r.master_safe_after_cycles = static_cast<int>(k - last_packet);
    }
    if (s == EngagementState::kAligning && !aligning_seen) {
      aligning_seen = true;
      aligning_from = k;
    }
    // While cut off: until aligning starts (a cut that trips the watchdog) or the first cycle with packets again.
    if (!aligning_seen && (k <= cut_end || r.safe_after_cycles >= 0))
      r.excursion_m = std::max(r.excursion_m, std::abs(x - x_cut));
    if (k >= cut_end && (engaged_at == 0 || k <= engaged_at + 100)) {
      r.reengage_step_m = std::max(r.reengage_step_m, std::abs(x - prev));
    }
    if (aligning_seen && engaged_at == 0 && s == EngagementState::kEngaged) {
      engaged_at = k;
      r.aligning_ms = static_cast<double>(k - aligning_from);
      r.reengaged = true;
    }
    if (!aligning_seen && k >= cut_end && s == EngagementState::kEngaged) r.reengaged = true;  // never left
    prev = x;
  }
  const RunSummary ss = rig.slave->Finish();
  (void)rig.master->Finish();
  r.reference_step_m = ss.engagement.max_reference_step_m;
  r.force_rate_N_per_s = ss.engagement.max_aligning_force_rate_N_per_s;
  r.slave_fault_records = ss.faults.size();
  if (!ss.faults.empty()) r.record = ss.faults.front().file;
  return r;
}

void PrintCutRow(const CutResult& r, const char* where) {
  const auto ms = [](int cycles) { return cycles < 0 ? std::string("-") : std::to_string(cycles); };
  std::printf("| %5d ms %-10s | %14s | %15s | %14.3f | %16.4f | %12.4f | %12.1f | %9.0f |\n", r.cut_ms, where,
              ms(r.safe_after_cycles).c_str(), ms(r.master_safe_after_cycles).c_str(), r.excursion_m * 1e3,
              r.reengage_step_m * 1e3, r.reference_step_m * 1e3, r.force_rate_N_per_s, r.aligning_ms);
}

TEST(NodeCut, CutsOf10msAnd100msAnd2sWhileTheMasterMoves) {
  std::printf(
      "| cut               | slave safe (ms)| master safe (ms)| excursion (mm) | re-engage step mm| ref step (mm)| "
      "force N/s    | align ms  |\n");
  for (const auto& [cut_ms, at_s, where] : {std::tuple{10, 1.0, "moving"}, std::tuple{100, 1.0, "moving"},
                                            std::tuple{2000, 0.5, "moving"}, std::tuple{2000, 0.6, "in fixture"}}) {
    const CutResult r = RunCut(cut_ms, at_s);
    PrintCutRow(r, where);
    SCOPED_TRACE("cut " + std::to_string(cut_ms) + " ms " + where);
    if (cut_ms <= kTimeoutCycles) {
      EXPECT_EQ(r.safe_after_cycles, -1) << "shorter than the timeout: stays engaged";
    } else {
      // The watchdog trips when the newest sample is older than the timeout: timeout + 1 cycle.
      EXPECT_GE(r.safe_after_cycles, kTimeoutCycles);
      EXPECT_LE(r.safe_after_cycles, kTimeoutCycles + 2) << "target: timeout plus at most 2 cycles";
      EXPECT_LE(r.master_safe_after_cycles, kTimeoutCycles + 2);
      EXPECT_GE(r.slave_fault_records, 1u);
      EXPECT_TRUE(std::filesystem::exists(r.record)) << r.record;
    }
    EXPECT_LE(r.excursion_m, 1e-3) << "target: at most 1 mm while cut off";
    EXPECT_LE(r.reengage_step_m, 0.1e-3) << "target: at most 0.1 mm per cycle at re-engagement";
    EXPECT_LE(r.reference_step_m, 0.1e-3);
    EXPECT_LE(r.force_rate_N_per_s, 100.0 + 1e-9) << "engagement.max_force_rate_N_per_s";
    EXPECT_TRUE(r.reengaged);
  }
}

TEST(NodeCut, WithoutABoundingAlignmentTheReengagementSteps) {
  // The same 2 s cut with an aligning that bounds nothing (10 m/s, no minimum time, 1e6 N/s): coupling comes back
  // as the step the issue measured before aligning existed, so the targets above are not met by construction.
  const CutResult r = RunCut(2000, 0.5,
                             "engagement: {align_speed_m_per_s: 10, align_min_time_ms: 0, "
                             "max_force_rate_N_per_s: 1000000}\n");
  PrintCutRow(r, "no bound");
  EXPECT_GT(r.master_travel_m, 5e-3) << "the master moved far during the cut";
  EXPECT_GT(r.reengage_step_m, 0.1e-3);
  EXPECT_GT(r.reference_step_m, 1e-3);
}

TEST(NodeCut, EveryReactionThroughA2sCut) {
  // A 2 s cut with the slave moving (1.0 s) and resting in its fixture (0.6 s), per pair of reactions. The latched
  // reactions keep the excursion within the target; `zero_force` lets the slave coast, so its excursion depends on
  // its speed at the loss: printed, not bounded.
  struct Row {
    const char* name;
    const char* master;
    const char* slave;
    double at_s;
    bool bounded;
  };
  for (const Row& row : {Row{"decel/damping", ", reaction: damping", ", reaction: decelerate", 1.0, true},
                         Row{"decel fixture", ", reaction: damping", ", reaction: decelerate", 0.6, true},
                         Row{"zero_force", ", reaction: zero_force", ", reaction: zero_force", 1.0, false},
                         Row{"zero fixture", ", reaction: zero_force", ", reaction: zero_force", 0.6, false}}) {
    const CutResult r = RunCut(2000, row.at_s, "", row.master, row.slave);
    PrintCutRow(r, row.name);
    SCOPED_TRACE(row.name);
    if (row.bounded) {
      EXPECT_LE(r.excursion_m, 1e-3);
    }
    EXPECT_LE(r.reengage_step_m, 0.1e-3);
    EXPECT_LE(r.force_rate_N_per_s, 100.0 + 1e-9);
    EXPECT_TRUE(r.reengaged);
  }
}

TEST(NodeCut, ANewSessionReengagesThroughAligning) {
  Rig rig;
  while (rig.cycle < 1000) rig.Step();
  ASSERT_EQ(rig.slave->engagement(), EngagementState::kEngaged);
  rig.slave_link->epoch = 1;  // e.g. the master restarted and the link authenticated a new session
  rig.Step();
  EXPECT_EQ(rig.slave->engagement(), EngagementState::kHandshaking);
  rig.Step();
  EXPECT_EQ(rig.slave->engagement(), EngagementState::kAligning) << "the new session's first sample";
  while (rig.cycle < 2000) rig.Step();
  EXPECT_EQ(rig.slave->engagement(), EngagementState::kEngaged);
  const RunSummary s = rig.slave->Finish();
  (void)rig.master->Finish();
  EXPECT_EQ(s.engagement.new_sessions, 1u);
  EXPECT_EQ(s.engagement.times_engaged, 2u);
  EXPECT_EQ(s.engagement.couplings_lost, 1u);
}

/// The rows of a telemetry CSV as maps from column name to value.
std::vector<std::map<std::string, double>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> names;
  std::vector<std::map<std::string, double>> rows;
  for (bool header = true; std::getline(in, line); header = false) {
    std::stringstream fields(line);
    std::string field;
    std::map<std::string, double> row;
    for (std::size_t i = 0; std::getline(fields, field, ','); ++i) {
      if (header) {
        names.push_back(field);
      } else if (i < names.size()) {
        row[names[i]] = std::strtod(field.c_str(), nullptr);
      }
    }
    if (!header) rows.push_back(std::move(row));
  }
  return rows;
}

TEST(NodeCut, ANewSessionForgetsThePeerInTheTelemetryToo) {
  // Until the new session's first sample the node holds no peer sample: the telemetry's peer columns are 0, not the
  // safe-state reaction's virtual peer (the hold target, zero velocity and force) nor the old session's sample.
  const std::string csv = FaultDir() + "/new_session_slave.csv";
  std::filesystem::remove(csv);
  Rig rig("", "", "", "telemetry: {csv: \"" + csv + "\"}\n");
  while (rig.cycle < 1000) rig.Step();
  ASSERT_EQ(rig.slave->engagement(), EngagementState::kEngaged);
  ASSERT_GT(std::abs(rig.slave_x()), 1e-3) << "the slave must be away from 0 for the check to mean something";
  rig.slave_link->epoch = 1;  // a new session whose first sample comes 5 cycles later
  rig.cut = true;
  for (int i = 0; i < 5; ++i) rig.Step();
  rig.cut = false;
  for (int i = 0; i < 5; ++i) rig.Step();
  (void)rig.slave->Finish();
  (void)rig.master->Finish();
  const auto rows = ReadCsv(csv);
  ASSERT_EQ(rows.size(), 1010u);
  for (const auto& r : rows) {
    const double cycle = r.at("cycle");
    if (cycle < 1000) continue;
    if (cycle < 1005) {
      EXPECT_EQ(static_cast<int>(r.at("engagement")), static_cast<int>(EngagementState::kHandshaking));
      EXPECT_EQ(r.at("peer_position_m_0"), 0.0) << "cycle " << cycle;
      EXPECT_EQ(r.at("peer_velocity_m_per_s_0"), 0.0) << "cycle " << cycle;
      EXPECT_EQ(r.at("peer_force_N_0"), 0.0) << "cycle " << cycle;
    } else if (cycle > 1005) {
      EXPECT_NE(r.at("peer_position_m_0"), 0.0) << "the new session's samples, cycle " << cycle;
    }
  }
}

TEST(NodeFault, EachDeviceFaultReachesTheSafeStateAndWritesItsRecord) {
  struct Case {
    const char* name;
    int cycles;  ///< How long the fault is injected.
    void (*inject)(FaultyDevice&);
    void (*clear)(FaultyDevice&);
  };
  const Case cases[] = {
      {"non-finite position", 20, [](FaultyDevice& d) { d.nan_position = true; },
       [](FaultyDevice& d) { d.nan_position = false; }},
      {"out of range", 20, [](FaultyDevice& d) { d.position_offset_m = 2.0; },
       [](FaultyDevice& d) { d.position_offset_m = 0.0; }},
      {"encoder glitch", 1, [](FaultyDevice& d) { d.position_offset_m = 0.05; },
       [](FaultyDevice& d) { d.position_offset_m = 0.0; }},
      {"driver timeout", 20, [](FaultyDevice& d) { d.fault_bits = device::kFaultCommunication; },
       [](FaultyDevice& d) { d.fault_bits = 0; }},
  };
  std::printf("| device fault        | safe state | SetSafe calls | master decoupled | record rows | re-engaged |\n");
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    Rig rig;
    while (rig.cycle < 800) rig.Step();
    ASSERT_EQ(rig.slave->engagement(), EngagementState::kEngaged);
    c.inject(*rig.slave_device);
    const std::uint64_t safe_before = rig.slave_device->safe_calls;
    rig.Step();
    const bool safe_now = rig.slave->engagement() == EngagementState::kDisengaged;
    const std::uint64_t safe_calls = rig.slave_device->safe_calls - safe_before;
    if (c.cycles == 1) c.clear(*rig.slave_device);  // a glitch: the reading jumps back (a second fault cycle)
    rig.Step();                                     // the master reads the fault flag one cycle later
    const bool master_off = rig.master->engagement() != EngagementState::kEngaged;
    for (int k = 2; k < c.cycles; ++k) rig.Step();
    c.clear(*rig.slave_device);
    for (int k = 0; k < 1500; ++k) rig.Step();
    const bool reengaged = rig.slave->engagement() == EngagementState::kEngaged;
    const RunSummary s = rig.slave->Finish();
    (void)rig.master->Finish();
    ASSERT_FALSE(s.faults.empty());
    const FaultReport& f = s.faults.front();
    int rows = -1;
    if (std::ifstream in(f.file); in) {
      std::string line;
      while (std::getline(in, line)) ++rows;
    }
    std::printf("| %-19s | %10s | %13llu | %16s | %11d | %10s |\n", c.name, safe_now ? "yes" : "NO",
                static_cast<unsigned long long>(safe_calls), master_off ? "yes" : "NO", rows, reengaged ? "yes" : "NO");
    EXPECT_TRUE(safe_now);
    EXPECT_EQ(safe_calls, 1u) << "Device::SetSafe in the fault cycle";
    EXPECT_TRUE(master_off) << "the peer sees the fault flag and decouples";
    EXPECT_EQ(f.kind, Outage::kDeviceFault);
    EXPECT_EQ(f.cycle, 800u);
    EXPECT_EQ(f.reaction, "device safe state");
    EXPECT_EQ(rows, 500) << "the last 500 cycles (safety.fault_record_cycles default)";
    EXPECT_TRUE(reengaged) << "back through aligning once the fault clears";
  }
}

TEST(NodeCut, TheLatencyGateDisengagesAndTheLinkComesBackThroughAligning) {
  // A 2 ms one-way delay gives a 4 ms round trip; the gate at 3 ms closes, at 10 ms it does not.
  for (const double limit_ms : {3.0, 10.0}) {
    transport::EmulatedMediumConfig mc;
    mc.master_to_slave.delay_s = 0.002;
    mc.slave_to_master.delay_s = 0.002;
    const std::string gate = "engagement: {max_rtt_ms: " + std::to_string(limit_ms) + "}\n";
    auto medium = std::make_shared<transport::EmulatedMedium>(mc);
    const auto mcfg = config::ParseProcessConfig(MasterConfig(), "master.yaml");
    const auto scfg = config::ParseProcessConfig(SlaveConfig(gate), "slave.yaml");
    TeleopNode master(mcfg, device::MakeDevice(mcfg.device),
                      std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster));
    TeleopNode slave(scfg, device::MakeDevice(scfg.device),
                     std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
    for (std::uint64_t k = 0; k < 1000; ++k) {
      const std::int64_t now_ns = 1'000'000'000 + static_cast<std::int64_t>(k) * 1'000'000;
      master.Step(k, kPeriod_s, now_ns);
      slave.Step(k, kPeriod_s, now_ns);
      medium->Advance(kPeriod_s);
    }
    const RunSummary s = slave.Finish();
    (void)master.Finish();
    if (limit_ms < 4.0) {
      EXPECT_EQ(slave.engagement(), EngagementState::kHandshaking);
      EXPECT_EQ(s.engagement.latency_gate_trips, 1u);
      ASSERT_FALSE(s.faults.empty());
      EXPECT_EQ(s.faults.front().kind, Outage::kLatency);
    } else {
      EXPECT_EQ(slave.engagement(), EngagementState::kEngaged);
      EXPECT_EQ(s.engagement.latency_gate_trips, 0u);
    }
  }
}

TEST(NodeCut, TheCycleAllocatesNothingThroughCutsFaultsAndReengagement) {
  Rig rig;
  while (rig.cycle < 500) rig.Step();
  test::AllocationCounter counter;
  for (int k = 0; k < 3000; ++k) {
    if (k == 100) rig.cut = true;
    if (k == 400) rig.cut = false;
    if (k == 1500) rig.slave_device->fault_bits = device::kFaultDriver;
    if (k == 1600) rig.slave_device->fault_bits = 0;
    rig.Step();
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(rig.slave->engagement(), EngagementState::kEngaged);
}

}  // namespace
}  // namespace teleop::node
