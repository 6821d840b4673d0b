#include "teleop/proto/can/frame_layout.hpp"

#include <array>

namespace teleop::proto::can {

namespace {

// The two slot tables of frame_layout.hpp. proto/teleop.dbc repeats them; tests/can/dbc_test.cpp checks that the
// two agree signal by signal.
constexpr std::array<SlotSignal, 6> kEvenSlot{{
    {SignalKind::kCounter, -1, 0, 4},
    {SignalKind::kFlags, -1, 4, 7},
    {SignalKind::kPosition, 0, 11, 14},
    {SignalKind::kVelocity, 0, 25, 11},
    {SignalKind::kForce, 0, 36, 12},
    {SignalKind::kPosition, 1, 48, 14},
}};
constexpr std::array<SlotSignal, 6> kOddSlot{{
    {SignalKind::kCounter, -1, 0, 4},
    {SignalKind::kVelocity, 1, 4, 11},
    {SignalKind::kForce, 1, 15, 12},
    {SignalKind::kPosition, 2, 27, 14},
    {SignalKind::kVelocity, 2, 41, 11},
    {SignalKind::kForce, 2, 52, 12},
}};

constexpr int PerDofBits() { return kPositionScaling.bits + kVelocityScaling.bits + kForceScaling.bits; }

}  // namespace

const FieldScaling& ScalingOf(SignalKind kind) noexcept {
  switch (kind) {
    case SignalKind::kCounter:
      return kCounterScaling;
    case SignalKind::kFlags:
      return kFlagsScaling;
    case SignalKind::kPosition:
      return kPositionScaling;
    case SignalKind::kVelocity:
      return kVelocityScaling;
    case SignalKind::kForce:
      break;
  }
  return kForceScaling;
}

double MaxAbsValue(const FieldScaling& scaling) noexcept {
  const int magnitude_bits = scaling.is_signed ? scaling.bits - 1 : scaling.bits;
  return static_cast<double>((std::int64_t{1} << magnitude_bits) - 1) * scaling.lsb;
}

std::span<const SlotSignal> SlotSignals(int slot) noexcept {
  if (slot % 2 == 0) return kEvenSlot;
  return kOddSlot;
}

int GlobalDof(int slot, const SlotSignal& signal) noexcept { return 3 * (slot / 2) + signal.dof_in_pair; }

bool SignalUsed(int slot, const SlotSignal& signal, int dof) noexcept {
  if (slot < 0 || slot >= SlotCount(dof)) return false;
  switch (signal.kind) {
    case SignalKind::kCounter:
      return true;
    case SignalKind::kFlags:
      return slot == 0;
    default:
      return GlobalDof(slot, signal) < dof;
  }
}

int SlotCount(int dof) noexcept {
  if (dof < 1) return 0;
  const int last = dof - 1;
  return 2 * (last / 3) + (last % 3 == 0 ? 1 : 2);
}

namespace {

int UsedEndBit(int slot, int dof) noexcept {
  int end_bit = 0;
  for (const SlotSignal& s : SlotSignals(slot)) {
    if (SignalUsed(slot, s, dof) && s.start_bit + s.length > end_bit) end_bit = s.start_bit + s.length;
  }
  return end_bit;
}

}  // namespace

int LayoutMarkerBit(int dof) noexcept { return UsedEndBit(0, dof); }

int SlotLength(int slot, int dof) noexcept {
  int end_bit = UsedEndBit(slot, dof);
  if (slot == 0 && end_bit > 0) ++end_bit;  // the layout marker
  return (end_bit + 7) / 8;
}

int PayloadBits(int dof) noexcept {
  if (dof < 1) return 0;
  return dof * PerDofBits() + kFlagsScaling.bits + kCounterBits;
}

int FdDataBytes(int dof) noexcept {
  const int slots = SlotCount(dof);
  if (slots == 0) return 0;
  return 8 * (slots - 1) + SlotLength(slots - 1, dof);
}

}  // namespace teleop::proto::can
