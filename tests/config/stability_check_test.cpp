// The start-up stability check of a process config (config::CheckProcessStability): the model it builds from a
// config, the verdicts and limits for the shipped configs, the refusal text, and the operator set.

#include "teleop/config/stability_check.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "analysis/sampled_simulation.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string Deploy(const char* name) { return std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/" + name; }

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in the config";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// The shipped slave config without its stability section (the defaults apply).
std::string SlaveWithoutStability() {
  const std::string text = ReadFile(Deploy("slave.yaml"));
  const auto at = text.find("\nstability:");
  EXPECT_NE(at, std::string::npos);
  return text.substr(0, at + 1);
}

// The shipped slave config for the tests that search for limits over and over. The sanitizer pass
// (TELEOP_SANITIZED_BUILD) searches over 2 operators per parameter (64: the grid's corners) instead of 4 (512):
// the same reader, model, search and verdict code with an eighth of the numeric work, which under ASan + UBSan is
// 10-20 s per test. The release suite checks the 512-operator figures.
std::string ShippedSlaveForRepeatedSearches() {
  const std::string text = ReadFile(Deploy("slave.yaml"));
#ifdef TELEOP_SANITIZED_BUILD
  return Replace(text, "human_grid_steps: 4", "human_grid_steps: 2");
#else
  return text;
#endif
}

std::string Whole(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f", value);
  return text;
}

// The demo slave: 2000 N/m at 1 kHz, K_p 600, K_d 2, 200 Hz filter, one-sample delay. docs/stability.md reports a
// limit of about 4120 N/m for it (the search stops within 0.1 %). The number is this code's own output; the test
// after this one checks it against the independent fine-step simulation.
TEST(StabilityCheck, ShippedSlaveIsStableBelowTheDocumentedLimit) {
  const ProcessConfig config = LoadProcessConfig(Deploy("slave.yaml"));
  const StabilityReport report = CheckProcessStability(config);
  ASSERT_EQ(report.axes.size(), 1u);
  EXPECT_TRUE(report.stable());
  EXPECT_EQ(report.operators, 512);
  const analysis::FixtureCheck& c = report.axes[0];
  EXPECT_EQ(c.side, analysis::FixtureSide::kSlave);
  EXPECT_EQ(c.stiffness_N_per_m, 2000.0);
  EXPECT_NEAR(c.limit.max_stable_stiffness_N_per_m, 4120.0, 0.005 * 4120.0);
  EXPECT_GT(c.at_configured.min_damping_ratio, 0.0);
  const std::string line = DescribePass(config, report);
  EXPECT_THAT(line, HasSubstr("stability check passed: slave fixture 2000 N/m, predicted limit " +
                              Whole(c.limit.max_stable_stiffness_N_per_m) + " N/m"));
  EXPECT_THAT(line, HasSubstr("margin "));
  EXPECT_THAT(line, HasSubstr("1000 Hz"));
  EXPECT_THAT(line, HasSubstr("peer delay 1 sample"));
}

// The figure above traced to something outside the eigenvalue code: the fine-step simulation of
// tests/analysis/sampled_simulation.hpp (RK4 on the continuous plant under held forces, the law of eqs. 8-9 with the
// backward-difference velocity, the 200 Hz filter and the one-sample delay, written from the paper and not from
// the state matrix). 2 % below the reported limit a perturbation dies out for the limiting operator and for the
// extreme operators of the grid; 2 % above it grows for the limiting operator. ±2 %: the reported figure is
// searched to 0.1 %, and at ±2 % the simulated envelope changes by about e^±6 over 10 000 samples (measured:
// ×0.002 below, ×360 above for the limiting operator), so the thresholds (×0.1, ×10) leave a wide margin; the
// simulation takes nothing from the analysis but the operator to try.
double EnvelopeRatio(const analysis::SampledTeleoperator& system, const analysis::HumanModel& human, int samples) {
  analysis::test::SampledSimulation sim(system, system.gains, human);
  sim.Perturb(1e-4, -1e-3);
  const int window = samples / 10;
  double start = 0.0;
  double end = 0.0;
  for (int k = 0; k < samples; ++k) {
    sim.Step();
    if (k >= window && k < 2 * window) start = std::max(start, sim.Magnitude());
    if (k >= samples - window) end = std::max(end, sim.Magnitude());
  }
  return end / start;
}

TEST(StabilityCheck, ShippedSlaveLimitAgreesWithTheFineStepSimulation) {
  const ProcessConfig config = LoadProcessConfig(Deploy("slave.yaml"));
  const StabilityReport report = CheckProcessStability(config);
  ASSERT_EQ(report.axes.size(), 1u);
  const double limit = report.axes[0].limit.max_stable_stiffness_N_per_m;
  const analysis::SampledTeleoperator model = StabilityModel(config, 0);
  const std::vector<analysis::HumanModel> grid = analysis::MakeHumanGrid(analysis::DefaultFingerBounds(), 4);
  ASSERT_EQ(grid.size(), 512u);
  constexpr int kSamples = 10000;
  for (const double factor : {0.98, 1.02}) {
    analysis::SampledTeleoperator at = model;
    at.gains = analysis::EffectiveGains(model, analysis::FixtureSide::kSlave);
    at.gains.slave_fixture_N_per_m = factor * limit;
    const double ratio = EnvelopeRatio(at, report.axes[0].limit.limiting_human, kSamples);
    if (factor < 1.0) {
      EXPECT_LT(ratio, 0.1) << "limiting operator at " << factor * limit << " N/m did not settle";
      for (const analysis::HumanModel& h : {grid.front(), grid.back()}) {
        EXPECT_LT(EnvelopeRatio(at, h, kSamples), 0.1) << "operator m=" << h.mass_kg << " k=" << h.stiffness_N_per_m;
      }
    } else {
      EXPECT_GT(ratio, 10.0) << "limiting operator at " << factor * limit << " N/m did not grow";
    }
  }
}

// sync.mode triggered: the slave's law sees the master's sample a fraction of a period late (by default the assumed
// data age of kTriggeredDataAge_s, or stability.peer_delay_fraction), the master the slave's reply one sample late. The
// pair is allowed a stiffer slave fixture than free-running, less than the paper's undelayed model, and the limit of
// that model is where the fine-step simulation of the same asymmetric delays turns unstable.
// Over CAN the master's sample is whole only once its last frame is on the wire: the triggered data age adds the
// cycle's frames at the configured bit rate (worst-case stuffing) and one frame of the slave's blocking the bus
// (docs/can.md, "Phase-locked cycles over CAN"). Expected values from the frame formulas, not from the code's path.
TEST(StabilityCheck, TriggeredOverCanCountsTheFramesOnTheBus) {
  const std::string shipped = SlaveWithoutStability();
  ProcessConfig c = ParseProcessConfig(shipped + "sync: {mode: triggered}\n", "slave.yaml");
  ASSERT_DOUBLE_EQ(c.loop.rate_hz, 1000.0);
  EXPECT_DOUBLE_EQ(TriggeredDataAge_s(c), kTriggeredDataAge_s) << "udp";
  const double udp_limit = CheckProcessStability(c).axes[0].limit.max_stable_stiffness_N_per_m;
  c.link.transport = "emulated-can";
  c.dof = 1;
  c.link.can.dof = 1;
  // 1 DOF, classic 1 Mbit/s, 11-bit: one 7-byte frame (CAN layout 2), 55 + 10·7 = 125 bits = 125 µs; the slave's is
  // the same.
  EXPECT_NEAR(TriggeredDataAge_s(c), kTriggeredDataAge_s + 2 * 125e-6, 1e-9);
  EXPECT_NEAR(*StabilityModel(c, 0).slave_peer_delay_fraction, (kTriggeredDataAge_s + 250e-6) * 1000.0, 1e-6);
  const double can_limit = CheckProcessStability(c).axes[0].limit.max_stable_stiffness_N_per_m;
  EXPECT_LT(can_limit, udp_limit) << "the frames' time makes the slave's data older than over UDP";
  // 250 kbit/s: 500 µs per frame, so the data age 100 + 1000 µs is over a period at 1 kHz: the fraction saturates.
  c.link.can.nominal_bitrate_bit_per_s = 250'000.0;
  EXPECT_NEAR(TriggeredDataAge_s(c), kTriggeredDataAge_s + 2 * 500e-6, 1e-9);
  EXPECT_DOUBLE_EQ(*StabilityModel(c, 0).slave_peer_delay_fraction, 1.0);
  // 6 DOF on CAN FD 1/5 Mbit/s: one 32-byte frame of 34 nominal + 358 data bits (docs/can.md): 105.6 µs each way.
  c.link.can.nominal_bitrate_bit_per_s = 1'000'000.0;
  c.link.can.fd = true;
  c.dof = 6;
  c.link.can.dof = 6;
  EXPECT_NEAR(TriggeredDataAge_s(c), kTriggeredDataAge_s + 2 * (34e-6 + 358 / 5e6), 1e-9);
}

TEST(StabilityCheck, TriggeredPairAllowsAStifferSlaveFixtureThatTheSimulationConfirms) {
  const std::string shipped = SlaveWithoutStability();  // the defaults of the stability section
  const ProcessConfig free = ParseProcessConfig(shipped, "slave.yaml");
  const ProcessConfig triggered = ParseProcessConfig(shipped + "sync: {mode: triggered}\n", "slave.yaml");
  const analysis::SampledTeleoperator model = StabilityModel(triggered, 0);
  ASSERT_TRUE(model.slave_peer_delay_fraction.has_value());
  EXPECT_DOUBLE_EQ(*model.slave_peer_delay_fraction, kTriggeredDataAge_s * 1000.0);
  EXPECT_EQ(model.peer_delay_samples, 1) << "the master still sees the slave's reply one sample late";
  EXPECT_FALSE(StabilityModel(free, 0).slave_peer_delay_fraction.has_value());
  const ProcessConfig measured =
      ParseProcessConfig(shipped + "sync: {mode: triggered}\nstability: {peer_delay_fraction: 0.3}\n", "slave.yaml");
  EXPECT_DOUBLE_EQ(*StabilityModel(measured, 0).slave_peer_delay_fraction, 0.3);

  const double free_limit = CheckProcessStability(free).axes[0].limit.max_stable_stiffness_N_per_m;
  const StabilityReport report = CheckProcessStability(triggered);
  const double limit = report.axes[0].limit.max_stable_stiffness_N_per_m;
  const double measured_limit = CheckProcessStability(measured).axes[0].limit.max_stable_stiffness_N_per_m;
  ProcessConfig paper = free;
  paper.stability.peer_delay_samples = 0;
  const double paper_limit = CheckProcessStability(paper).axes[0].limit.max_stable_stiffness_N_per_m;
  EXPECT_GT(limit, free_limit * 1.01) << "fresher data on the slave allows a stiffer fixture";
  EXPECT_LT(limit, paper_limit) << "but not as stiff as with no delay on either side";
  EXPECT_LT(measured_limit, limit) << "an older data age allows less";
  EXPECT_GT(measured_limit, free_limit);

  constexpr int kSamples = 10000;
  for (const double factor : {0.98, 1.02}) {
    analysis::SampledTeleoperator at = model;
    at.gains = analysis::EffectiveGains(model, analysis::FixtureSide::kSlave);
    at.gains.slave_fixture_N_per_m = factor * limit;
    const double ratio = EnvelopeRatio(at, report.axes[0].limit.limiting_human, kSamples);
    if (factor < 1.0) {
      EXPECT_LT(ratio, 0.1) << "limiting operator at " << factor * limit << " N/m did not settle";
    } else {
      EXPECT_GT(ratio, 10.0) << "limiting operator at " << factor * limit << " N/m did not grow";
    }
  }
}

TEST(StabilityCheck, ShippedMasterIsStable) {
  const ProcessConfig config = LoadProcessConfig(Deploy("master.yaml"));
  const StabilityReport report = CheckProcessStability(config);
  ASSERT_EQ(report.axes.size(), 1u);
  EXPECT_TRUE(report.stable());
  EXPECT_EQ(report.axes[0].side, analysis::FixtureSide::kMaster);
  EXPECT_EQ(report.axes[0].stiffness_N_per_m, 0.0);
  EXPECT_GT(report.axes[0].limit.max_stable_stiffness_N_per_m, 4000.0);
  EXPECT_THAT(DescribePass(config, report), HasSubstr("no fixture"));
}

// The defaults (section absent) are what the shipped section spells out: the same model, the same limit, bit for bit.
TEST(StabilityCheck, AbsentSectionMeansPaperPeerWithTheSameGains) {
  const ProcessConfig explicit_section = LoadProcessConfig(Deploy("slave.yaml"));
  const ProcessConfig defaults = ParseProcessConfig(SlaveWithoutStability(), "slave.yaml");
  const analysis::SampledTeleoperator m = StabilityModel(defaults, 0);
  EXPECT_EQ(m.master.mass_kg, analysis::kPaperMasterDevice.mass_kg);
  EXPECT_EQ(m.master.damping_Ns_per_m, analysis::kPaperMasterDevice.damping_Ns_per_m);
  EXPECT_EQ(m.slave.mass_kg, 0.036);  // the loopback plant
  EXPECT_EQ(m.slave.damping_Ns_per_m, 0.49);
  EXPECT_EQ(m.gains.kps_N_per_m, 600.0);
  EXPECT_EQ(m.gains.kpm_N_per_m, 600.0);
  EXPECT_EQ(m.gains.kds_Ns_per_m, 2.0);
  EXPECT_EQ(m.gains.kdm_Ns_per_m, 2.0);
  EXPECT_EQ(m.gains.slave_fixture_N_per_m, 2000.0);
  EXPECT_EQ(m.gains.master_fixture_N_per_m, 0.0);
  EXPECT_EQ(m.rate_hz, 1000.0);
  EXPECT_EQ(m.velocity_filter_hz, 200.0);
  EXPECT_EQ(m.peer_delay_samples, 1);
  EXPECT_FALSE(m.unilateral);
  EXPECT_EQ(CheckProcessStability(defaults).axes[0].limit.max_stable_stiffness_N_per_m,
            CheckProcessStability(explicit_section).axes[0].limit.max_stable_stiffness_N_per_m);
}

TEST(StabilityCheck, PeerDescriptionEntersTheModel) {
  const std::string text = ReadFile(Deploy("master.yaml"));
  const ProcessConfig with_fixture = ParseProcessConfig(text, "master.yaml");
  const ProcessConfig without =
      ParseProcessConfig(Replace(Replace(text, "fixture_stiffness_N_per_m: 2000", "fixture_stiffness_N_per_m: 0"),
                                 "kd_Ns_per_m: 2\n    kv", "kd_Ns_per_m: 5\n    kv"),
                         "master.yaml");
  const analysis::SampledTeleoperator a = StabilityModel(with_fixture, 0);
  EXPECT_EQ(a.gains.slave_fixture_N_per_m, 2000.0);
  EXPECT_EQ(a.slave.mass_kg, 0.036);
  EXPECT_EQ(a.gains.kds_Ns_per_m, 2.0);
  const analysis::SampledTeleoperator b = StabilityModel(without, 0);
  EXPECT_EQ(b.gains.slave_fixture_N_per_m, 0.0);
  EXPECT_EQ(b.gains.kds_Ns_per_m, 5.0);
  EXPECT_EQ(b.gains.kdm_Ns_per_m, 2.0) << "the master's own gain is its law's";
  const double limit_a = CheckProcessStability(with_fixture).axes[0].limit.max_stable_stiffness_N_per_m;
  const double limit_b = CheckProcessStability(without).axes[0].limit.max_stable_stiffness_N_per_m;
  EXPECT_GT(std::abs(limit_a - limit_b), 0.01 * limit_a) << limit_a << " vs " << limit_b;
}

TEST(StabilityCheck, AboveTheLimitFailsAndTheMessageNamesLimitStiffnessAndRemedy) {
  const ProcessConfig config = ParseProcessConfig(
      Replace(ReadFile(Deploy("slave.yaml")), "stiffness_N_per_m: 2000", "stiffness_N_per_m: 6000"), "slave.yaml");
  const StabilityReport report = CheckProcessStability(config);
  EXPECT_FALSE(report.stable());
  const analysis::FixtureCheck& c = report.worst();
  EXPECT_LT(c.at_configured.min_damping_ratio, 0.0);
  EXPECT_FALSE(c.limit.unstable_without_fixture);
  const std::string text = DescribeFailure(config, report);
  EXPECT_THAT(text, HasSubstr("slave.yaml: slave fixture 6000 N/m is above the predicted stability limit " +
                              Whole(c.limit.max_stable_stiffness_N_per_m) + " N/m"));
  EXPECT_THAT(text, HasSubstr("Lower fixture.stiffness_N_per_m to at most " +
                              Whole(std::floor(c.limit.max_stable_stiffness_N_per_m)) + " N/m"));
}

TEST(StabilityCheck, JustBelowAndJustAboveTheLimit) {
  const std::string text = ReadFile(Deploy("slave.yaml"));
  const double limit =
      CheckProcessStability(LoadProcessConfig(Deploy("slave.yaml"))).axes[0].limit.max_stable_stiffness_N_per_m;
  const auto verdict = [&](double stiffness) {
    const ProcessConfig c =
        ParseProcessConfig(Replace(text, "stiffness_N_per_m: 2000", "stiffness_N_per_m: " + Whole(stiffness)), "s");
    return CheckProcessStability(c).stable();
  };
  EXPECT_TRUE(verdict(0.99 * limit));
  EXPECT_FALSE(verdict(1.01 * limit));
}

// At 250 Hz with the one-sample delay the coupling itself is unstable (docs/stability.md): refused even at 0 N/m.
TEST(StabilityCheck, CouplingUnstableWithoutFixtureIsRefused) {
  std::string text = SlaveWithoutStability();
  text = Replace(text, "rate_hz: 1000", "rate_hz: 250");
  text = Replace(text, "velocity_filter_hz: 200", "velocity_filter_hz: 100");
  text = Replace(text, "stiffness_N_per_m: 2000", "stiffness_N_per_m: 0");
  const ProcessConfig config = ParseProcessConfig(text, "slow.yaml");
  const StabilityReport report = CheckProcessStability(config);
  EXPECT_FALSE(report.stable());
  EXPECT_TRUE(report.worst().limit.unstable_without_fixture);
  EXPECT_EQ(report.worst().limit.max_stable_stiffness_N_per_m, 0.0);
  const std::string message = DescribeFailure(config, report);
  EXPECT_THAT(message, HasSubstr("UNSTABLE even without a fixture (predicted limit 0 N/m, configured fixture 0 N/m"));
  EXPECT_THAT(message, HasSubstr("Raise rate_hz"));
  // The units and the assumptions are separate words ("0 N/m, 250 Hz"), not glued ("0 N/m250 Hz").
  EXPECT_THAT(message, HasSubstr("configured fixture 0 N/m, 250 Hz, bilateral"));
  EXPECT_THAT(message, ::testing::Not(::testing::ContainsRegex("N/m[0-9]")));
}

// Per DOF: each axis with its own gains; the fixture only along the axes its planes touch; identical axes analysed
// once; the worst axis is the failing one.
TEST(StabilityCheck, EveryAxisWithItsOwnGains) {
  std::string text = Replace(ShippedSlaveForRepeatedSearches(), "dof: 1", "dof: 3");
  text = Replace(text, "kd_Ns_per_m: 2\n  kv", "kd_Ns_per_m: [1, 2, 2]\n  kv");
  text = Replace(text, "half_space: {axis: 0", "half_space: {axis: 2");
  text = Replace(text, "stiffness_N_per_m: 2000", "stiffness_N_per_m: 3000");
  const ProcessConfig config = ParseProcessConfig(text, "s3.yaml");
  EXPECT_EQ(StabilityModel(config, 0).gains.slave_fixture_N_per_m, 0.0);
  EXPECT_EQ(StabilityModel(config, 1).gains.slave_fixture_N_per_m, 0.0);
  EXPECT_EQ(StabilityModel(config, 2).gains.slave_fixture_N_per_m, 3000.0);
  EXPECT_EQ(StabilityModel(config, 0).gains.kds_Ns_per_m, 1.0);
  EXPECT_EQ(StabilityModel(config, 0).gains.kdm_Ns_per_m, 2.0) << "the peer's K_d comes from the stability section";
  EXPECT_THROW(StabilityModel(config, 3), Error);
  const StabilityReport report = CheckProcessStability(config);
  ASSERT_EQ(report.axes.size(), 3u);
  EXPECT_TRUE(report.stable());
  // K_d matters (docs/stability.md: K_d strongly): axis 0 has the lower limit.
  EXPECT_LT(report.axes[0].limit.max_stable_stiffness_N_per_m, 0.9 * report.axes[1].limit.max_stable_stiffness_N_per_m);
  // Axes 1 and 2 differ only in their own fixture, which the search ignores: the same limit.
  EXPECT_EQ(report.axes[1].limit.max_stable_stiffness_N_per_m, report.axes[2].limit.max_stable_stiffness_N_per_m);
  int smallest_margin = 0;
  for (int i = 1; i < 3; ++i) {
    const auto margin = [&](int a) {
      const analysis::FixtureCheck& c = report.axes[static_cast<std::size_t>(a)];
      return c.limit.max_stable_stiffness_N_per_m - c.stiffness_N_per_m;
    };
    if (margin(i) < margin(smallest_margin)) smallest_margin = i;
  }
  EXPECT_EQ(report.worst_axis(), smallest_margin);

  text = Replace(text, "stiffness_N_per_m: 3000", "stiffness_N_per_m: 4500");
  const StabilityReport above = CheckProcessStability(ParseProcessConfig(text, "s3.yaml"));
  EXPECT_FALSE(above.stable());
  EXPECT_EQ(above.worst_axis(), 2);
  EXPECT_THAT(DescribeFailure(ParseProcessConfig(text, "s3.yaml"), above), HasSubstr("axis 2"));
}

// human_bounds is relative to the config file; the shipped CSV is the built-in table, so the limit is the same.
TEST(StabilityCheck, HumanBoundsFileRelativeToTheConfig) {
  const test::ScopedTempDir dir("stability");
  std::filesystem::copy_file(Deploy("human_bounds_finger.csv"), dir.path() / "finger.csv");
  const std::string text =
      Replace(ReadFile(Deploy("slave.yaml")), "human_bounds: \"\"", "human_bounds: \"finger.csv\"");
  const std::string config_path = (dir.path() / "slave.yaml").string();
  std::ofstream(config_path) << text;
  const ProcessConfig config = LoadProcessConfig(config_path);
  EXPECT_EQ(StabilityOperators(config).size(), 512u);
  EXPECT_EQ(CheckProcessStability(config).axes[0].limit.max_stable_stiffness_N_per_m,
            CheckProcessStability(LoadProcessConfig(Deploy("slave.yaml"))).axes[0].limit.max_stable_stiffness_N_per_m);

  std::ofstream(config_path) << Replace(text, "finger.csv", "missing.csv");
  try {
    CheckProcessStability(LoadProcessConfig(config_path));
    ADD_FAILURE() << "a missing bounds file must be an error";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("missing.csv"));
  }
}

TEST(StabilityCheck, GridStepsSetTheOperatorCount) {
  const ProcessConfig config = ParseProcessConfig(
      Replace(ReadFile(Deploy("slave.yaml")), "human_grid_steps: 4", "human_grid_steps: 2"), "slave.yaml");
  EXPECT_EQ(StabilityOperators(config).size(), 8u * 2u * 2u * 2u);
  EXPECT_EQ(CheckProcessStability(config).operators, 64);
}

// The reader allows velocity_filter_hz up to rate/2; the model needs it strictly below Nyquist. That config is an
// error at start-up with a message, never a crash.
TEST(StabilityCheck, ModelOutsideTheAnalysisRangeIsAnError) {
  // The reader refuses a velocity filter at the Nyquist frequency...
  const std::string text = Replace(ReadFile(Deploy("slave.yaml")), "rate_hz: 1000", "rate_hz: 400");
  EXPECT_THROW((void)ParseProcessConfig(text, "slave.yaml"), Error);
  // ...and a config built in code that gets there anyway is an error of the check, not a crash.
  ProcessConfig config = ParseProcessConfig(ReadFile(Deploy("slave.yaml")), "slave.yaml");
  config.law.velocity_filter_hz = config.loop.rate_hz / 2.0;
  try {
    CheckProcessStability(config);
    ADD_FAILURE() << "expected teleop::Error";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("velocity_filter_hz"));
  }
}

}  // namespace
}  // namespace teleop::config

namespace teleop::config {
namespace {

// Issue 32.2: the check assumes the link's expected delay (link.expected_delay_ms, else the emulated link's delay +
// jitter) on top of the pair's one sample, and says which. The shipped slave fixture (2000 N/m) is stable at one
// sample (limit ~4120 N/m) and refused over a 4 ms link (5 samples: limit ~680 N/m, teleop-analyze max-stiffness
// --side slave --kp 600 --kd 2 --link-delay-ms 4), with the reproducing command line in the message.
TEST(StabilityCheck, RefusesAFixtureStableAtOneSampleButNotAtTheConfiguredDelay) {
  const std::string shipped = ShippedSlaveForRepeatedSearches();
  const ProcessConfig lab = ParseProcessConfig(shipped, "slave.yaml");
  const StabilityReport at_one = CheckProcessStability(lab);
  ASSERT_TRUE(at_one.stable());
  EXPECT_THAT(DescribePass(lab, at_one), HasSubstr("assumed no link delay"));

  const ProcessConfig wan = ParseProcessConfig(
      Replace(shipped, "  timeout_ms: 50\n", "  timeout_ms: 50\n  expected_delay_ms: 4\n"), "slave.yaml");
  EXPECT_DOUBLE_EQ(AssumedLinkDelay_s(wan), 4e-3);
  EXPECT_EQ(analysis::PeerDelaysOf(StabilityModel(wan, 0)).slave_to_master(), 5.0);
  const StabilityReport at_five = CheckProcessStability(wan);
  EXPECT_FALSE(at_five.stable());
  const double limit = at_five.worst().limit.max_stable_stiffness_N_per_m;
  EXPECT_GT(limit, 300.0);
  EXPECT_LT(limit, 1000.0);
  EXPECT_LT(limit, 0.5 * at_one.worst().limit.max_stable_stiffness_N_per_m);
  const std::string failure = DescribeFailure(wan, at_five);
  EXPECT_THAT(failure, HasSubstr("peer delay 5 samples"));
  EXPECT_THAT(failure, HasSubstr("assumed link.expected_delay_ms 4 ms"));
  EXPECT_THAT(failure, HasSubstr("teleop-analyze max-stiffness --side slave --rate 1000 --kpm 600 --kps 600"));
  EXPECT_THAT(failure, HasSubstr("--peer-delay-samples 5 --peer-delay-fraction 0 --slave-peer-delay-samples 5"));

  // Without the key, the emulated link's delay + jitter (3 + 1 ms); the key overrides it.
  const std::string emulated =
      Replace(shipped, "  timeout_ms: 50\n", "  timeout_ms: 50\n  emulate: {delay_ms: 3, jitter_ms: 1}\n");
  const ProcessConfig emu = ParseProcessConfig(emulated, "slave.yaml");
  EXPECT_DOUBLE_EQ(AssumedLinkDelay_s(emu), 4e-3);
  EXPECT_THAT(DescribeAssumedLinkDelay(emu), HasSubstr("emulated link's delay + jitter 4 ms"));
  const ProcessConfig emu_override = ParseProcessConfig(
      Replace(emulated, "  timeout_ms: 50\n", "  timeout_ms: 50\n  expected_delay_ms: 0\n"), "slave.yaml");
  EXPECT_DOUBLE_EQ(AssumedLinkDelay_s(emu_override), 0.0);
  EXPECT_TRUE(CheckProcessStability(emu_override).stable());
}

}  // namespace
}  // namespace teleop::config
