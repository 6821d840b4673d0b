// teleop-supervise's view of a process: staleness, status precedence, and the table / CSV / JSON record formats.
#include "teleop/dds/process_view.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace teleop::dds {
namespace {

using ::testing::HasSubstr;

constexpr std::int64_t kSecond_ns = 1'000'000'000;

ProcessView LiveView() {
  ProcessView v;
  v.pair = "rigA";
  v.role = "slave";
  v.have_state = true;
  v.last_state_ns = 10 * kSecond_ns;
  v.state_rate_hz = 20.0;
  v.rate_hz = 1000.0;
  v.achieved_rate_hz = 999.5;
  v.loss_fraction = 0.0125;
  v.packets_lost = 3;
  v.rtt_ms = 0.25;
  v.engagement = Engagement::kCoupled;
  v.writer_matched = true;
  return v;
}

TEST(ProcessView, StaleAfterTheLimitButNeverBeforeThreeStatePeriods) {
  ProcessView v = LiveView();
  EXPECT_DOUBLE_EQ(StaleLimit_s(v, 1.0), 1.0);
  v.state_rate_hz = 1.0;  // 3 periods = 3 s > 1 s
  EXPECT_DOUBLE_EQ(StaleLimit_s(v, 1.0), 3.0);
  v.state_rate_hz = 20.0;
  EXPECT_EQ(StatusOf(v, 10 * kSecond_ns + kSecond_ns / 2, 1.0), ProcessView::Status::kLive);
  EXPECT_EQ(StatusOf(v, 10 * kSecond_ns + kSecond_ns + 1'000'000, 1.0), ProcessView::Status::kStale);
}

TEST(ProcessView, SummaryThenWriterLeftThenStateDecideTheStatus) {
  ProcessView v = LiveView();
  const std::int64_t late_ns = 100 * kSecond_ns;
  EXPECT_EQ(StatusOf(v, late_ns, 1.0), ProcessView::Status::kStale);
  v.writer_left = true;
  EXPECT_EQ(StatusOf(v, late_ns, 1.0), ProcessView::Status::kGone);
  v.have_summary = true;
  EXPECT_EQ(StatusOf(v, late_ns, 1.0), ProcessView::Status::kFinished);
  ProcessView fresh;
  EXPECT_EQ(StatusOf(fresh, late_ns, 1.0), ProcessView::Status::kDiscovered);
}

TEST(ProcessView, TableShowsTheFiguresInTheirUnits) {
  ProcessView v = LiveView();
  v.status = ProcessView::Status::kLive;
  v.age_s = 0.04;
  v.device_faults = 0x2;
  v.tracking_error_m = 0.0012;
  v.last_event = "peer_connected";
  const std::string table = FormatTable({v});
  EXPECT_THAT(table, HasSubstr("PAIR"));
  EXPECT_THAT(table, HasSubstr("rigA"));
  EXPECT_THAT(table, HasSubstr("live"));
  EXPECT_THAT(table, HasSubstr(" 1000 "));   // 999.5 Hz rounded
  EXPECT_THAT(table, HasSubstr(" 1.25 "));   // loss in %
  EXPECT_THAT(table, HasSubstr(" 0.250 "));  // ms
  EXPECT_THAT(table, HasSubstr("coupled"));
  EXPECT_THAT(table, HasSubstr("0x2"));
  EXPECT_THAT(table, HasSubstr(" 1.200 "));  // mm
  EXPECT_THAT(table, HasSubstr("peer_connected"));
  EXPECT_THAT(table, HasSubstr("CLUTCH"));
  EXPECT_THAT(table, HasSubstr(" K_N/M LIMIT_N/M "));
  v.fixture_stiffness_N_per_m = 2000.0;
  EXPECT_THAT(FormatTable({v}), HasSubstr(" 2000         - ")) << "no limit computed: '-', not 0";
  v.clutch = 1 | 4;  // the device's pedal and the command channel
  EXPECT_THAT(FormatTable({v}), HasSubstr(" device+command "));
}

TEST(ProcessView, ClutchTextNamesTheSources) {
  EXPECT_EQ(ClutchText(0), "-");
  EXPECT_EQ(ClutchText(1), "device");
  EXPECT_EQ(ClutchText(2), "peer");
  EXPECT_EQ(ClutchText(4), "command");
  EXPECT_EQ(ClutchText(7), "device+peer+command");
  EXPECT_EQ(ClutchText(0x12), "peer+other");
}

TEST(ProcessView, JsonLinesWriteNullForUnknownNumbersAndEscapeText) {
  ProcessView v = LiveView();
  v.rtt_ms = std::numeric_limits<double>::quiet_NaN();
  v.status = ProcessView::Status::kStale;
  v.age_s = 1.5;
  const std::string line = JsonStateLine(v, 2.5);
  EXPECT_THAT(line,
              HasSubstr("\"type\":\"state\",\"t_s\":2.5,\"pair\":\"rigA\",\"role\":\"slave\",\"status\":\"stale\""));
  EXPECT_THAT(line, HasSubstr("\"rtt_ms\":null"));
  EXPECT_THAT(line, HasSubstr("\"loss_fraction\":0.0125"));
  EXPECT_THAT(line, HasSubstr("\"rate_hz\":1000,\"achieved_rate_hz\":999.5,"));
  EXPECT_THAT(line, HasSubstr("\"packets_lost\":3,"));
  EXPECT_THAT(line, HasSubstr("\"engagement\":\"coupled\",\"clutch\":0,"));
  EXPECT_THAT(line, HasSubstr("\"last_event\":\"\","));
  // A Cartesian process that computes no limit: null, and no joints.
  EXPECT_THAT(line, HasSubstr("\"fixture_limit_N_per_m\":null,\"joint_position_rad\":[],\"joint_torque_Nm\":[]}"));
  EXPECT_EQ(line.find('\n'), std::string::npos);
  EXPECT_EQ(JsonString("a\"b\\c\nd\x01"), "\"a\\\"b\\\\c\\nd\\u0001\"");
  v.have_summary = true;
  v.summary_json = "{\n  \"role\": \"slave\"\n}";
  const std::string summary = JsonSummaryLine(v, 3.0);
  EXPECT_THAT(summary, HasSubstr("\"summary_json\":\"{\\n  \\\"role\\\": \\\"slave\\\"\\n}\""));
}

TEST(ProcessView, CsvRowMatchesTheHeader) {
  const auto count = [](const std::string& s) { return std::count(s.begin(), s.end(), ','); };
  ProcessView v = LiveView();
  v.rtt_ms = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(count(CsvRow(v, 1.0)), count(CsvHeader()));
  EXPECT_THAT(CsvRow(v, 1.0), HasSubstr(",3,"));  // packets_lost
  v.clutch = 2;
  EXPECT_THAT(CsvRow(v, 1.0), HasSubstr(",coupled,2,"));  // engagement, clutch
}

}  // namespace
}  // namespace teleop::dds
