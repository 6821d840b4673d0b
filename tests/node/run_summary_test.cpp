// The run summary's link_emulation field (link.emulate, docs/link-emulation.md): null without emulation, every
// counter by name with it, in the JSON and the text.
#include "teleop/node/run_summary.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace teleop::node {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

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
