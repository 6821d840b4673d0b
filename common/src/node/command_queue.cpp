#include "command_queue.hpp"

namespace teleop::node {

namespace {

DofVector FromArray(const std::array<double, kMaxDof>& in, int dof) noexcept {
  DofVector out(dof);
  for (int i = 0; i < dof; ++i) out[i] = in[static_cast<std::size_t>(i)];
  return out;
}

void Fold(const PendingCommand& p, int dof, Changes& changes) noexcept {
  using Change = PendingCommand::Change;
  switch (p.change) {
    case Change::kNone:
      break;
    case Change::kStiffness:
      changes.has_stiffness = true;
      changes.stiffness = {p.stiffness_N_per_m, p.ramp_s};
      break;
    case Change::kGains:
      changes.has_gains = true;
      changes.gains = {FromArray(p.gains[0], dof), FromArray(p.gains[1], dof), FromArray(p.gains[2], dof),
                       FromArray(p.gains[3], dof), p.ramp_s};
      break;
    case Change::kPlane:
      changes.has_plane = true;
      changes.plane = {0, FromArray(p.normal, dof), p.offset_m, p.offset_rate_m_per_s, p.normal_rate_rad_per_s};
      break;
    case Change::kPassivity:
      changes.has_passivity = true;
      changes.passivity_mode = p.passivity_mode;
      break;
  }
}

}  // namespace

Changes CommandQueue::Drain(bool command_clutch, std::uint64_t cycle, EventLog& events) noexcept {
  Changes changes;
  changes.command_clutch = command_clutch;
  PendingCommand p;
  for (int n = 0; n < kPerCycle && ring_.TryPop(p); ++n) {
    Fold(p, dof_, changes);
    events.Push({p.kind, cycle, p.value, p.detail});
  }
  return changes;
}

}  // namespace teleop::node
