#include "teleop/proto/can/sample_codec.hpp"

#include <cmath>

namespace teleop::proto::can {

namespace {

constexpr std::uint64_t FieldMask(int length) noexcept {
  return length >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << length) - 1;
}

std::uint64_t LoadLittleEndian(const std::uint8_t* bytes, std::size_t len) noexcept {
  std::uint64_t word = 0;
  for (std::size_t i = 0; i < len && i < 8; ++i) word |= std::uint64_t{bytes[i]} << (8 * i);
  return word;
}

void StoreLittleEndian(std::uint64_t word, std::uint8_t* bytes, std::size_t len) noexcept {
  for (std::size_t i = 0; i < len && i < 8; ++i) bytes[i] = static_cast<std::uint8_t>(word >> (8 * i));
}

std::int32_t NotANumberCode(const FieldScaling& scaling) noexcept { return -(std::int32_t{1} << (scaling.bits - 1)); }

std::int32_t SignExtend(std::uint64_t raw, int length) noexcept {
  const std::uint64_t sign = std::uint64_t{1} << (length - 1);
  return static_cast<std::int32_t>(static_cast<std::int64_t>(raw ^ sign) - static_cast<std::int64_t>(sign));
}

void SetField(SampleMessage& m, SignalKind kind, int dof, double value) noexcept {
  const auto i = static_cast<std::size_t>(dof);
  switch (kind) {
    case SignalKind::kPosition:
      m.position_m[i] = value;
      break;
    case SignalKind::kVelocity:
      m.velocity_m_per_s[i] = value;
      break;
    case SignalKind::kForce:
      m.force_N[i] = value;
      break;
    default:
      break;
  }
}

double FieldValue(const SampleMessage& m, SignalKind kind, int dof) noexcept {
  const auto i = static_cast<std::size_t>(dof);
  switch (kind) {
    case SignalKind::kPosition:
      return m.position_m[i];
    case SignalKind::kVelocity:
      return m.velocity_m_per_s[i];
    case SignalKind::kForce:
      return m.force_N[i];
    default:
      return 0.0;
  }
}

// The layout marker of slot 0 (frame_layout.hpp): always 1 in layout 2, 0 (reserved) in layout 1.
std::uint64_t LayoutMarker(int dof) noexcept { return std::uint64_t{1} << LayoutMarkerBit(dof); }

// Bits of `slot` that must be 0 for `dof` DOF: every bit of its `bytes` bytes not covered by a used signal.
std::uint64_t ReservedMask(int slot, int dof, int bytes) noexcept {
  std::uint64_t used = 0;
  for (const SlotSignal& s : SlotSignals(slot)) {
    if (SignalUsed(slot, s, dof)) used |= FieldMask(s.length) << s.start_bit;
  }
  if (slot == 0) used |= LayoutMarker(dof);
  return FieldMask(8 * bytes) & ~used;
}

std::uint64_t EncodeSlot(const SampleMessage& m, int slot, int dof, EncodeResult& result) noexcept {
  std::uint64_t word = 0;
  for (const SlotSignal& s : SlotSignals(slot)) {
    if (!SignalUsed(slot, s, dof)) continue;
    std::uint64_t raw = 0;
    if (s.kind == SignalKind::kCounter) {
      raw = m.sequence % kCounterModulo;
    } else if (s.kind == SignalKind::kFlags) {
      raw = m.flags & FieldMask(s.length);
    } else {
      const double value = FieldValue(m, s.kind, GlobalDof(slot, s));
      bool saturated = false;
      const std::int32_t code = Quantize(value, ScalingOf(s.kind), saturated);
      if (!std::isfinite(value)) ++result.non_finite;
      if (saturated) ++result.saturated;
      raw = static_cast<std::uint64_t>(static_cast<std::int64_t>(code));
    }
    word |= (raw & FieldMask(s.length)) << s.start_bit;
  }
  if (slot == 0) word |= LayoutMarker(dof);
  return word;
}

}  // namespace

std::int32_t Quantize(double value, const FieldScaling& scaling, bool& saturated) noexcept {
  saturated = false;
  if (!std::isfinite(value)) return NotANumberCode(scaling);
  const std::int32_t max_code = (std::int32_t{1} << (scaling.bits - 1)) - 1;
  const double counts = std::round(value / scaling.lsb);
  if (counts > static_cast<double>(max_code)) {
    saturated = true;
    return max_code;
  }
  if (counts < static_cast<double>(-max_code)) {
    saturated = true;
    return -max_code;
  }
  return static_cast<std::int32_t>(counts);
}

EncodeResult EncodeCycle(const SampleMessage& message, const CanWireFormat& format, std::span<CanFrame> out) noexcept {
  EncodeResult result{};
  if (CheckFormat(format) != FormatStatus::kOk || message.dof != format.dof) return result;
  const int frames = FramesPerCycle(format);
  if (out.size() < static_cast<std::size_t>(frames)) return result;
  const int dof = format.dof;
  const int slots = SlotCount(dof);
  const std::uint32_t base = BaseIdOf(format, message.sender);
  if (format.fd) {
    CanFrame& f = out[0];
    f = CanFrame{};
    f.id = base + kFdIdOffset;
    f.extended = format.extended_id;
    f.fd = true;
    f.brs = format.brs;
    f.len = static_cast<std::uint8_t>(RoundUpToFdLength(static_cast<std::size_t>(FdDataBytes(dof))));
    for (int k = 0; k < slots; ++k) {
      const std::uint64_t word = EncodeSlot(message, k, dof, result);
      StoreLittleEndian(word, &f.data[8 * static_cast<std::size_t>(k)], 8);
    }
  } else {
    for (int k = 0; k < slots; ++k) {
      CanFrame& f = out[static_cast<std::size_t>(k)];
      f = CanFrame{};
      f.id = base + static_cast<std::uint32_t>(k);
      f.extended = format.extended_id;
      f.len = static_cast<std::uint8_t>(SlotLength(k, dof));
      StoreLittleEndian(EncodeSlot(message, k, dof, result), f.data.data(), f.len);
    }
  }
  result.frames = frames;
  return result;
}

const char* ToString(FrameStatus status) noexcept {
  switch (status) {
    case FrameStatus::kPending:
      return "pending";
    case FrameStatus::kComplete:
      return "complete";
    case FrameStatus::kUnknownId:
      return "unknown_id";
    case FrameStatus::kBadFormat:
      return "bad_format";
    case FrameStatus::kBadLength:
      return "bad_length";
    case FrameStatus::kReservedBits:
      return "reserved_bits";
    case FrameStatus::kDuplicateFrame:
      return "duplicate_frame";
    case FrameStatus::kNonFinite:
      return "non_finite";
    case FrameStatus::kCounterMismatch:
      return "counter_mismatch";
    case FrameStatus::kOldLayout:
      return "old_layout";
    case FrameStatus::kCount:
      break;
  }
  return "invalid";
}

CycleAssembler::CycleAssembler(const CanWireFormat& format, SenderRole peer) noexcept
    : format_(format),
      peer_(peer),
      base_id_(BaseIdOf(format, peer)),
      slots_(SlotCount(format.dof)),
      all_slots_mask_(static_cast<std::uint8_t>((1u << SlotCount(format.dof)) - 1u)) {
  for (int k = 0; k < slots_ && k < kMaxSlots; ++k) {
    const int bytes = format_.fd && k < slots_ - 1 ? 8 : SlotLength(k, format_.dof);
    reserved_mask_[static_cast<std::size_t>(k)] = ReservedMask(k, format_.dof, bytes);
  }
}

int CycleAssembler::partial_cycles() const noexcept {
  int n = 0;
  for (const Assembly& a : assemblies_) n += a.in_use ? 1 : 0;
  return n;
}

void CycleAssembler::Reset() noexcept {
  for (Assembly& a : assemblies_) {
    if (a.in_use) ++abandoned_;
    a.in_use = false;
  }
}

void CycleAssembler::Tick() noexcept {
  ++tick_;
  for (Assembly& a : assemblies_) {
    if (a.in_use && tick_ - a.touched_tick >= kExpiryTicks) {
      a.in_use = false;
      ++abandoned_;
    }
  }
}

FrameStatus CycleAssembler::Push(const CanFrame& frame, SampleMessage& out) noexcept {
  if (frame.error || frame.remote || frame.fd != format_.fd) return FrameStatus::kBadFormat;
  if (frame.extended != format_.extended_id) return FrameStatus::kUnknownId;
  if (FramesPerCycle(format_) == 0) return FrameStatus::kBadFormat;  // dof outside the range of this CAN kind
  return format_.fd ? PushFd(frame, out) : PushClassic(frame, out);
}

FrameStatus CycleAssembler::PushClassic(const CanFrame& frame, SampleMessage& out) noexcept {
  if (frame.id < base_id_ || frame.id >= base_id_ + static_cast<std::uint32_t>(slots_)) {
    return FrameStatus::kUnknownId;
  }
  const int slot = static_cast<int>(frame.id - base_id_);
  if (slot == 0 && format_.dof == 1 && frame.len == kLayout1OneDofSlotBytes) return FrameStatus::kOldLayout;
  if (frame.len != SlotLength(slot, format_.dof)) return FrameStatus::kBadLength;
  const std::uint64_t word = LoadLittleEndian(frame.data.data(), frame.len);
  if (slot == 0 && (word & LayoutMarker(format_.dof)) == 0) return FrameStatus::kOldLayout;
  if ((word & reserved_mask_[static_cast<std::size_t>(slot)]) != 0) return FrameStatus::kReservedBits;
  const auto counter = static_cast<std::uint8_t>(word & FieldMask(kCounterBits));
  const auto bit = static_cast<std::uint8_t>(1u << slot);

  Assembly* target = nullptr;
  for (Assembly& a : assemblies_) {
    if (a.in_use && a.counter == counter) target = &a;
  }
  if (target != nullptr && (target->received_mask & bit) != 0) return FrameStatus::kDuplicateFrame;
  if (target == nullptr) {
    for (Assembly& a : assemblies_) {
      if (!a.in_use) {
        target = &a;
        break;
      }
    }
    if (target == nullptr) {  // all busy: drop the oldest partial cycle
      target = &assemblies_[0];
      for (Assembly& a : assemblies_) {
        if (a.age < target->age) target = &a;
      }
      ++abandoned_;
    }
    *target = Assembly{};
    target->in_use = true;
    target->counter = counter;
    target->age = next_age_++;
  }
  target->touched_tick = tick_;
  target->received_mask = static_cast<std::uint8_t>(target->received_mask | bit);
  target->slot_bits[static_cast<std::size_t>(slot)] = word;
  if (target->received_mask != all_slots_mask_) return FrameStatus::kPending;

  // Complete. Partial cycles started before this one can only be older cycles whose frames were lost: drop them,
  // so that a buffer never waits long enough for its 4-bit counter to come round again.
  const std::uint64_t completed_age = target->age;
  const std::array<std::uint64_t, kMaxSlots> slots = target->slot_bits;
  target->in_use = false;
  for (Assembly& a : assemblies_) {
    if (a.in_use && a.age < completed_age) {
      a.in_use = false;
      ++abandoned_;
    }
  }
  return Decode(slots, out);
}

FrameStatus CycleAssembler::PushFd(const CanFrame& frame, SampleMessage& out) noexcept {
  if (frame.id != base_id_ + kFdIdOffset) return FrameStatus::kUnknownId;
  const std::size_t data_bytes = static_cast<std::size_t>(FdDataBytes(format_.dof));
  if (format_.dof == 1 && frame.len == kLayout1OneDofSlotBytes) return FrameStatus::kOldLayout;
  if (frame.len != RoundUpToFdLength(data_bytes)) return FrameStatus::kBadLength;
  if ((LoadLittleEndian(frame.data.data(), 8) & LayoutMarker(format_.dof)) == 0) return FrameStatus::kOldLayout;
  for (std::size_t i = data_bytes; i < frame.len; ++i) {
    if (frame.data[i] != 0) return FrameStatus::kReservedBits;
  }
  std::array<std::uint64_t, kMaxSlots> slots{};
  for (int k = 0; k < slots_; ++k) {
    const std::size_t offset = 8 * static_cast<std::size_t>(k);
    const std::size_t bytes = k < slots_ - 1 ? 8 : data_bytes - offset;
    const std::uint64_t word = LoadLittleEndian(&frame.data[offset], bytes);
    if ((word & reserved_mask_[static_cast<std::size_t>(k)]) != 0) return FrameStatus::kReservedBits;
    slots[static_cast<std::size_t>(k)] = word;
    if ((word & FieldMask(kCounterBits)) != (slots[0] & FieldMask(kCounterBits))) {
      return FrameStatus::kCounterMismatch;
    }
  }
  return Decode(slots, out);
}

FrameStatus CycleAssembler::Decode(const std::array<std::uint64_t, kMaxSlots>& slots,
                                   SampleMessage& out) const noexcept {
  SampleMessage m{};
  m.sender = peer_;
  m.dof = static_cast<std::uint8_t>(format_.dof);
  for (int k = 0; k < slots_; ++k) {
    const std::uint64_t word = slots[static_cast<std::size_t>(k)];
    for (const SlotSignal& s : SlotSignals(k)) {
      if (!SignalUsed(k, s, format_.dof)) continue;
      const std::uint64_t raw = (word >> s.start_bit) & FieldMask(s.length);
      if (s.kind == SignalKind::kCounter) {
        m.sequence = static_cast<std::uint32_t>(raw);
      } else if (s.kind == SignalKind::kFlags) {
        m.flags = static_cast<std::uint8_t>(raw);
      } else {
        const FieldScaling& scaling = ScalingOf(s.kind);
        const std::int32_t code = SignExtend(raw, s.length);
        if (code == NotANumberCode(scaling)) return FrameStatus::kNonFinite;
        SetField(m, s.kind, GlobalDof(k, s), static_cast<double>(code) * scaling.lsb);
      }
    }
  }
  out = m;
  return FrameStatus::kComplete;
}

std::uint32_t ExtendCounter(std::uint32_t reference, std::uint8_t counter) noexcept {
  const std::uint32_t delta = (static_cast<std::uint32_t>(counter) - reference) % kCounterModulo;  // 0..15
  const std::int32_t signed_delta =
      delta < kCounterModulo / 2 ? static_cast<std::int32_t>(delta) : static_cast<std::int32_t>(delta) - kCounterModulo;
  return reference + static_cast<std::uint32_t>(signed_delta);
}

}  // namespace teleop::proto::can
