// The processes' exit statuses (teleop/node/exit_codes.hpp), which the systemd units' restart policy relies on.
#include "teleop/node/exit_codes.hpp"

#include <gtest/gtest.h>

namespace teleop::node {
namespace {

TEST(ExitCodes, CleanRunExitsZero) {
  RunSummary s;
  s.cycles = 1000;
  s.watchdog_trips = 3;  // a peer that went away and came back is not a latched fault
  s.link.lost = 12;
  EXPECT_EQ(ExitCodeFor(s), kExitOk);
}

TEST(ExitCodes, DeviceFaultIsLatched) {
  RunSummary s;
  s.device_fault_cycles = 1;
  EXPECT_EQ(ExitCodeFor(s), kExitFaulted);
}

TEST(ExitCodes, NonFiniteInputIsLatched) {
  RunSummary s;
  s.nonfinite_inputs = 1;
  EXPECT_EQ(ExitCodeFor(s), kExitFaulted);
}

TEST(ExitCodes, NeverConnectedHasItsOwnStatus) {
  RunSummary s;
  s.cycles = 1000;
  s.connected = false;
  EXPECT_EQ(ExitCodeFor(s), kExitNeverConnected);
  s.device_fault_cycles = 1;  // a fault is the more urgent news
  EXPECT_EQ(ExitCodeFor(s), kExitFaulted);
}

TEST(ExitCodes, StatusesAreDistinct) {
  EXPECT_EQ(kExitOk, 0);
  const int statuses[] = {kExitConfigError, kExitUnexpectedError, kExitFaulted, kExitNeverConnected};
  for (const int& a : statuses) {
    for (const int& b : statuses) {
      if (&a != &b) {
        EXPECT_NE(a, b);
      }
    }
  }
  // 1 is what a shell or a crashing wrapper reports for anything; CLI11's own errors are >= 100.
  for (const int s : statuses) {
    EXPECT_GT(s, 1);
    EXPECT_LT(s, 100);
  }
}

}  // namespace
}  // namespace teleop::node
