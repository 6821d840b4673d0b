#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace teleop::dds {

/// DDS topic and type names of the bridge, following the ROS 2 mapping (docs/dds.md): the ROS 2 topic
/// `/teleop/<pair>/<role>/<leaf>` is the DDS topic `rt/teleop/<pair>/<role>/<leaf>`, and the ROS 2 message
/// `teleop_msgs/msg/<Name>` is the DDS type `teleop_msgs::msg::dds_::<Name>_`.
inline constexpr std::string_view kTopicPrefix = "rt/teleop/";
inline constexpr std::string_view kStateLeaf = "state";
inline constexpr std::string_view kEventsLeaf = "events";
inline constexpr std::string_view kSummaryLeaf = "summary";
inline constexpr std::string_view kStateTypeName = "teleop_msgs::msg::dds_::State_";
inline constexpr std::string_view kEventTypeName = "teleop_msgs::msg::dds_::Event_";
inline constexpr std::string_view kSummaryTypeName = "teleop_msgs::msg::dds_::RunSummary_";
inline constexpr std::size_t kMaxPairNameLength = 64;

/// True when `token` is a valid ROS 2 name token: [A-Za-z][A-Za-z0-9_]*, no "__", at most kMaxPairNameLength.
inline bool IsValidNameToken(std::string_view token) noexcept {
  if (token.empty() || token.size() > kMaxPairNameLength) return false;
  const auto alpha = [](char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); };
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  if (!alpha(token.front())) return false;
  for (std::size_t i = 0; i < token.size(); ++i) {
    const char c = token[i];
    if (!alpha(c) && !digit(c) && c != '_') return false;
    if (c == '_' && i + 1 < token.size() && token[i + 1] == '_') return false;
  }
  return true;
}

/// "rt/teleop/<pair>/<role>/<leaf>".
inline std::string TopicName(std::string_view pair, std::string_view role, std::string_view leaf) {
  std::string name(kTopicPrefix);
  name.append(pair).append("/").append(role).append("/").append(leaf);
  return name;
}

/// The parts of a bridge topic name.
struct TopicParts {
  std::string pair;
  std::string role;  ///< "master" or "slave".
  std::string leaf;  ///< "state", "events" or "summary".
};

/// Splits "rt/teleop/<pair>/<role>/<leaf>"; nullopt for any other name (another ROS 2 node's topic, a bad role).
inline std::optional<TopicParts> ParseTopicName(std::string_view name) {
  if (name.substr(0, kTopicPrefix.size()) != kTopicPrefix) return std::nullopt;
  name.remove_prefix(kTopicPrefix.size());
  const std::size_t a = name.find('/');
  if (a == std::string_view::npos) return std::nullopt;
  const std::size_t b = name.find('/', a + 1);
  if (b == std::string_view::npos || name.find('/', b + 1) != std::string_view::npos) return std::nullopt;
  TopicParts parts{std::string(name.substr(0, a)), std::string(name.substr(a + 1, b - a - 1)),
                   std::string(name.substr(b + 1))};
  if (!IsValidNameToken(parts.pair) || (parts.role != "master" && parts.role != "slave")) return std::nullopt;
  if (parts.leaf != kStateLeaf && parts.leaf != kEventsLeaf && parts.leaf != kSummaryLeaf) return std::nullopt;
  return parts;
}

}  // namespace teleop::dds
