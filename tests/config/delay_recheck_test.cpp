// Issue 32.3, the run-time re-check: the decision with hysteresis (runtime::DelayWatch) and the check re-run with the
// measured delay (config::DelayRecheck), on the shipped slave config (K_p 600, K_d 2, fixture 2000 N/m).

#include "teleop/config/delay_recheck.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"

namespace teleop {
namespace {

using runtime::DelayWatch;
using ::testing::HasSubstr;

// 1 kHz of data ages: 1 ms ± 0.1 ms for 1 s, then 60 ms ± 5 ms for 2 s, then 1 ms again for 3 s. Fires once when the
// delay steps up (within the window), never while it stays at 60 ms with its jitter, and recovers once, only after
// the hold; a link hovering inside the hysteresis band (1.1..1.25 × assumed) neither fires nor recovers.
TEST(DelayWatch, StepFromOneToSixtyMsFiresOnceAndRecoversAfterTheHold) {
  DelayWatch::Config c;
  c.assumed_age_s = 1e-3;
  c.window_s = 0.2;
  c.recover_hold_s = 0.5;
  DelayWatch watch(c);
  std::vector<std::pair<double, DelayWatch::Verdict>> verdicts;
  double t = 0.0;
  auto feed = [&](double seconds, double age_s, double jitter_s) {
    for (int k = 0; k < static_cast<int>(seconds * 1000.0); ++k, t += 1e-3) {
      const double wobble = jitter_s * std::sin(0.37 * k);  // deterministic jitter
      const DelayWatch::Verdict v = watch.Add(t, age_s + wobble);
      if (v != DelayWatch::Verdict::kNone) verdicts.emplace_back(t, v);
    }
  };
  feed(1.0, 1e-3, 1e-4);
  EXPECT_TRUE(verdicts.empty());
  feed(2.0, 60e-3, 5e-3);
  ASSERT_EQ(verdicts.size(), 1u);
  EXPECT_EQ(verdicts[0].second, DelayWatch::Verdict::kSlower);
  EXPECT_LT(verdicts[0].first - 1.0, 0.2) << "fired later than one window after the step";
  EXPECT_GT(watch.reported_age_s(), 55e-3);
  EXPECT_TRUE(watch.slower());
  feed(3.0, 1e-3, 1e-4);
  ASSERT_EQ(verdicts.size(), 2u);
  EXPECT_EQ(verdicts[1].second, DelayWatch::Verdict::kRecovered);
  // The window must first clear of the 60 ms samples (0.2 s), then the hold (0.5 s).
  EXPECT_GT(verdicts[1].first - 3.0, 0.5);
  EXPECT_LT(verdicts[1].first - 3.0, 0.8);
  EXPECT_FALSE(watch.slower());

  // Inside the band: 1.18 ms ± 0.05 ms never fires.
  DelayWatch band(c);
  for (int k = 0; k < 3000; ++k) {
    EXPECT_EQ(band.Add(k * 1e-3, 1.18e-3 + 5e-5 * std::sin(0.37 * k)), DelayWatch::Verdict::kNone);
  }
  // Bad samples are counted, not used; bad configs refused.
  EXPECT_EQ(band.Add(4.0, std::nan("")), DelayWatch::Verdict::kNone);
  EXPECT_EQ(band.Add(4.0, -1.0), DelayWatch::Verdict::kNone);
  EXPECT_EQ(band.rejected(), 2u);
  DelayWatch::Config bad = c;
  bad.recover_ratio = 2.0;  // above the trigger: no hysteresis
  EXPECT_THROW(DelayWatch{bad}, Error);
}

std::string ShippedSlave(const std::string& extra = "") {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/slave.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  // 8 operators instead of 512: the re-check stays well under a second here (and under ASan + UBSan).
  const std::string key = "  human_grid_steps: 4";
  yaml.replace(yaml.find(key), key.size(), "  human_grid_steps: 1");
  return yaml + extra;
}

// At a measured data age of 4 ms (3 ms of link on top of the period) the shipped slave's limit is ~1950 N/m: the
// fixture goes to 0.9 × that, over |Δk| × 10 mm / 20 N/s. At 8 ms no stiffness is stable (the coupling itself is not,
// from 5 ms on): the fixture goes to 0 and the action says so. (8 ms, not a WAN's 60: at 60 ms the model has 130
// states and one Evaluate takes ~15 s in the sanitized build, against 0.1 s in the release build.)
TEST(DelayRecheck, EvaluateLowersTheShippedSlaveFixtureToTheLimitAtTheMeasuredDelay) {
  const config::ProcessConfig config = config::ParseProcessConfig(ShippedSlave(), "slave.yaml");
  EXPECT_DOUBLE_EQ(config::DelayRecheck::AssumedAge_s(config), 1e-3);
  const config::DelayRecheck::Options options;
  const auto at4 = config::DelayRecheck::Evaluate(config, options, 4e-3, 2000.0);
  EXPECT_FALSE(at4.coupling_unstable);
  EXPECT_GT(at4.limit_N_per_m, 1700.0);
  EXPECT_LT(at4.limit_N_per_m, 2200.0);
  EXPECT_NEAR(at4.fixture_N_per_m, 0.9 * at4.limit_N_per_m, 1e-9);
  EXPECT_NEAR(at4.ramp_s, (2000.0 - at4.fixture_N_per_m) * 0.01 / 20.0, 1e-12);
  EXPECT_THAT(at4.message, HasSubstr("data age 4.0 ms (the check assumed 1.0 ms)"));
  EXPECT_THAT(at4.message, HasSubstr("teleop-analyze max-stiffness --side slave"));
  const auto at8 = config::DelayRecheck::Evaluate(config, options, 8e-3, 2000.0);
  EXPECT_TRUE(at8.coupling_unstable);
  EXPECT_EQ(at8.fixture_N_per_m, 0.0);
  EXPECT_THAT(at8.message, HasSubstr("the coupling itself is unstable"));
}

// The thread on the shipped slave with a short window and hold, fed the data age `age_s`; every action it takes is
// appended to `actions` under `mutex`, and `changed` is notified.
struct Recorded {
  static config::DelayRecheck::Options ShortWindow() {
    config::DelayRecheck::Options o;
    o.poll_period_s = 1e-3;
    o.watch.window_s = 0.02;
    o.watch.recover_hold_s = 0.02;
    return o;
  }
  std::atomic<double> age_s{1e-3};
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<config::DelayRecheck::Action> actions;
  config::DelayRecheck recheck{config::ParseProcessConfig(ShippedSlave(), "slave.yaml"), ShortWindow(),
                               [this] { return age_s.load(); },
                               [this](const config::DelayRecheck::Action& a) {
                                 const std::lock_guard<std::mutex> lock(mutex);
                                 actions.push_back(a);
                                 changed.notify_all();
                               }};
};

// The thread: a data age that steps 1 -> 4 -> 1 ms; the re-check lowers the fixture once (to 0.9 x the limit at
// 4 ms) and restores it once, each over |dk| x 10 mm / 20 N/s.
TEST(DelayRecheck, ThreadLowersOnAStepAndRestoresWhenTheLinkRecovers) {
  Recorded r;
  std::atomic<double>& age_s = r.age_s;
  std::condition_variable& changed = r.changed;
  std::vector<config::DelayRecheck::Action>& actions = r.actions;
  std::unique_lock<std::mutex> lock(r.mutex);
  EXPECT_FALSE(changed.wait_for(lock, std::chrono::milliseconds(50), [&] { return !actions.empty(); }));
  age_s = 4e-3;
  ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(10), [&] { return actions.size() >= 1; }));
  EXPECT_FALSE(actions[0].recovered);
  EXPECT_FALSE(actions[0].coupling_unstable);
  EXPECT_NEAR(actions[0].fixture_N_per_m, 0.9 * actions[0].limit_N_per_m, 1e-9);
  EXPECT_LT(actions[0].fixture_N_per_m, 2000.0);
  const double lowered = actions[0].fixture_N_per_m;
  age_s = 1e-3;
  ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(10), [&] { return actions.size() >= 2; }));
  EXPECT_TRUE(actions[1].recovered);
  EXPECT_EQ(actions[1].fixture_N_per_m, 2000.0);
  EXPECT_NEAR(actions[1].ramp_s, (2000.0 - lowered) * 0.01 / 20.0, 1e-12);
  EXPECT_EQ(actions.size(), 2u);
}

// At 8 ms no fixture is stable with the shipped gains (the coupling itself is not): the action says so and leaves
// the fixture where it is (the process decides: an event, decouple or passivity on); the recovery that follows
// is reported (the process undoes what it switched) with the stiffness unchanged and no ramp.
TEST(DelayRecheck, ACouplingUnstableAtTheMeasuredDelayLeavesTheFixtureAloneAndReportsTheRecovery) {
  Recorded r;
  std::atomic<double>& age_s = r.age_s;
  std::condition_variable& changed = r.changed;
  std::vector<config::DelayRecheck::Action>& actions = r.actions;
  config::DelayRecheck& recheck = r.recheck;
  std::unique_lock<std::mutex> lock(r.mutex);
  age_s = 8e-3;  // not 60: ~15 s per check under ASan + UBSan (above)
  ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(10), [&] { return actions.size() >= 1; }));
  EXPECT_TRUE(actions[0].coupling_unstable);
  EXPECT_FALSE(actions[0].failed);
  age_s = 1e-3;
  ASSERT_TRUE(changed.wait_for(lock, std::chrono::seconds(10), [&] { return actions.size() >= 2; }));
  EXPECT_TRUE(actions[1].recovered);
  EXPECT_FALSE(actions[1].coupling_unstable);
  EXPECT_EQ(actions[1].fixture_N_per_m, 2000.0);
  EXPECT_EQ(actions[1].ramp_s, 0.0);
  EXPECT_FALSE(changed.wait_for(lock, std::chrono::milliseconds(300), [&] { return actions.size() >= 3; }));
  EXPECT_EQ(recheck.actions(), 2);
}

}  // namespace
}  // namespace teleop
