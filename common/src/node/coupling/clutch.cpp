#include "clutch.hpp"

namespace teleop::node {

Clutch::Output Clutch::Step(const Input& in) noexcept {
  Output out;
  if (in.device_pressed) out.sources |= kClutchDevice;
  if (in.command_pressed) out.sources |= kClutchCommand;
  if (in.peer_pressed) out.sources |= kClutchPeer;
  out.pressed = out.sources != 0 && state_.sources == 0;
  out.released = out.sources == 0 && state_.sources != 0;
  if (out.pressed) ++state_.presses;
  state_.sources = out.sources;
  out.blocker = in.blocker == Outage::kNone && out.sources != 0 ? Outage::kClutch : in.blocker;
  out.clutch_path = out.blocker == Outage::kClutch && (config_.master || config_.can_push);
  // The master's flag also carries the peer's clutch and a pending re-index: the slave holds until the master's
  // samples carry the re-indexed position. The slave's carries only its own (no latch between the two).
  const std::uint8_t own = out.sources & static_cast<std::uint8_t>(kClutchDevice | kClutchCommand);
  out.flag = config_.master ? (out.sources != 0 || in.index_pending) : own != 0;
  return out;
}

}  // namespace teleop::node
