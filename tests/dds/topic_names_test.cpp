// ROS 2 naming of the bridge's topics and types (docs/dds.md), and the engagement classification.
#include "teleop/dds/topic_names.hpp"

#include <gtest/gtest.h>

#include "teleop/dds/bridge_sample.hpp"

namespace teleop::dds {
namespace {

TEST(TopicNames, FollowTheRos2Mapping) {
  EXPECT_EQ(TopicName("rigA", "master", kStateLeaf), "rt/teleop/rigA/master/state");
  EXPECT_EQ(TopicName("rig_2", "slave", kSummaryLeaf), "rt/teleop/rig_2/slave/summary");
  EXPECT_EQ(kStateTypeName, "teleop_msgs::msg::dds_::State_");
  EXPECT_EQ(kEventTypeName, "teleop_msgs::msg::dds_::Event_");
  EXPECT_EQ(kSummaryTypeName, "teleop_msgs::msg::dds_::RunSummary_");
}

TEST(TopicNames, ParseRoundTripsAndRejectsOthers) {
  const auto parts = ParseTopicName("rt/teleop/rigA/slave/events");
  ASSERT_TRUE(parts.has_value());
  EXPECT_EQ(parts->pair, "rigA");
  EXPECT_EQ(parts->role, "slave");
  EXPECT_EQ(parts->leaf, "events");
  for (const char* other : {"rt/chatter", "rt/teleop/rigA/master", "rt/teleop/rigA/operator/state",
                            "rt/teleop/rigA/master/state/x", "rq/teleop/rigA/master/state", "rt/teleop//master/state",
                            "rt/teleop/rigA/master/pose", "rt/teleop/9rig/master/state"}) {
    EXPECT_FALSE(ParseTopicName(other).has_value()) << other;
  }
}

TEST(TopicNames, NameTokens) {
  EXPECT_TRUE(IsValidNameToken("a"));
  EXPECT_TRUE(IsValidNameToken("Rig_12"));
  EXPECT_FALSE(IsValidNameToken(""));
  EXPECT_FALSE(IsValidNameToken("_rig"));
  EXPECT_FALSE(IsValidNameToken("rig-1"));
  EXPECT_FALSE(IsValidNameToken("rig__1"));
  EXPECT_FALSE(IsValidNameToken(std::string(kMaxPairNameLength + 1, 'a')));
  EXPECT_TRUE(IsValidNameToken(std::string(kMaxPairNameLength, 'a')));
}

TEST(Engagement, PrecedenceOfTheInputs) {
  EngagementInputs in;
  EXPECT_EQ(EngagementOf(in), Engagement::kWaiting);
  in.have_peer = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kPeerLost);
  in.peer_fresh = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kCoupled);
  in.engaged = false;  // handshaking or aligning: a fresh peer is not yet coupling
  EXPECT_EQ(EngagementOf(in), Engagement::kAligning);
  EXPECT_STREQ(ToString(Engagement::kAligning), "aligning");
  in.peer_fresh = false;
  EXPECT_EQ(EngagementOf(in), Engagement::kPeerLost);
  in.peer_fresh = true;
  in.engaged = true;
  in.peer_fault = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kFault);
  in.peer_fault = false;
  in.peer_shutdown = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kPeerShutdown);
  in.local_fault = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kFault);
  in.stopping = true;
  EXPECT_EQ(EngagementOf(in), Engagement::kStopping);
  EXPECT_STREQ(ToString(Engagement::kPeerLost), "peer_lost");
}

}  // namespace
}  // namespace teleop::dds
