// A build without Cyclone DDS (TELEOP_DDS=OFF) refuses dds.enabled at start-up with a message naming the packages.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "teleop/dds/bridge.hpp"
#include "teleop/error.hpp"

namespace teleop::dds {
namespace {

TEST(BridgeUnavailable, RefusesToStartAndSaysWhatToInstall) {
  if (Bridge::Available()) GTEST_SKIP() << "this build has the DDS bridge (TELEOP_DDS=ON); see dds_bridge_test";
  BridgeConfig config;
  config.enabled = true;
  try {
    Bridge bridge(config, Role::kMaster, 1000.0);
    FAIL() << "a bridge was created without DDS";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("cyclonedds-dev"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("dds.enabled: false"));
  }
}

}  // namespace
}  // namespace teleop::dds
