#pragma once

#include <cstdint>
#include <span>

namespace teleop::proto::can {

// The CAN frame layout of a sample (docs/can.md, proto/teleop.dbc). A cycle's sample is split into "slots" of at
// most 8 bytes. Classic CAN sends slot k as one frame with identifier base + k; CAN FD sends all slots of a cycle
// as one frame with identifier base + kFdIdOffset, slot k at bytes 8k..8k+7. Slots come in pairs; pair p carries
// DOF 3p, 3p+1, 3p+2 in 2 × 64 bits:
//
//   even slot 2p: Counter 0|4, Flags 4|7 (slot 0; reserved 0 in slot 2), Position[3p] 11|14, Velocity[3p] 25|11,
//                 Force[3p] 36|12, Position[3p+1] 48|14, reserved 62..63
//   slot 0 also carries the layout marker: one bit, always 1, right after its last used signal (bit 62; bit 48 for
//   1 DOF, whose slot 0 is then 7 bytes). Layout 1 (6-bit Flags, no clutch) had 0 there (reserved) and a 6-byte
//   1-DOF slot, so a receiver tells a layout-1 frame from a layout-2 one (kOldLayout) instead of misreading it,
//   and a layout-1 receiver refuses a layout-2 frame (reserved bit set, or the 1-DOF length).
//   odd slot 2p+1: Counter 0|4, Velocity[3p+1] 4|11, Force[3p+1] 15|12, Position[3p+2] 27|14,
//                  Velocity[3p+2] 41|11, Force[3p+2] 52|12
//
// (start bit | length, Intel bit order: bit b is bit b%8 of byte b/8.) A slot is only as long as the signals the
// configured DOF count needs (1 DOF: 7 bytes); everything in a slot not covered by a used signal is reserved and
// must be 0. Physical values are signed fixed point with the LSB below, saturated (never wrapped) to
// ±(2^(n-1) - 1) LSB; the code -2^(n-1) means "not a number" (the sender had a NaN/inf) and makes the receiver
// reject the cycle.

/// What a signal carries.
enum class SignalKind : std::uint8_t { kCounter, kFlags, kPosition, kVelocity, kForce };

/// Fixed-point scaling of one kind of signal.
struct FieldScaling {
  const char* name;  ///< Signal name stem in the DBC ("Position").
  const char* unit;  ///< SI unit ("m", "m/s", "N"; rotational DOF use rad, rad/s, N·m with the same numbers).
  int bits;          ///< Width on the wire.
  double lsb;        ///< Value of one count, in `unit`.
  bool is_signed;    ///< Two's complement.
};

inline constexpr FieldScaling kCounterScaling{"Counter", "", 4, 1.0, false};
inline constexpr FieldScaling kFlagsScaling{"Flags", "", 7, 1.0, false};            // StateFlags bits 0..6
inline constexpr FieldScaling kPositionScaling{"Position", "m", 14, 20e-6, true};   // ±0.16382 m
inline constexpr FieldScaling kVelocityScaling{"Velocity", "m/s", 11, 2e-3, true};  // ±2.046 m/s
inline constexpr FieldScaling kForceScaling{"Force", "N", 12, 10e-3, true};         // ±20.47 N

const FieldScaling& ScalingOf(SignalKind kind) noexcept;
/// Largest magnitude a signed field represents: (2^(bits-1) - 1) · lsb.
double MaxAbsValue(const FieldScaling& scaling) noexcept;

/// One signal of a slot. `dof_in_pair` is 0..2 for per-DOF signals (global DOF = 3·(slot/2) + dof_in_pair), -1 for
/// the counter and flags.
struct SlotSignal {
  SignalKind kind;
  int dof_in_pair;
  int start_bit;
  int length;
};

/// Version of this layout (the DBC's VERSION "teleop-can-2"). 1: Flags 6 bits (no kFlagClutched), no marker. There is
/// no version field on CAN: the layout marker of slot 0 tells layout 2 from layout 1 (docs/can.md, "Layout version").
inline constexpr int kCanLayoutVersion = 2;
/// Bytes of slot 0 for 1 DOF in layout 1 (6; layout 2: 7): a 1-DOF frame of this length is a layout-1 frame.
inline constexpr int kLayout1OneDofSlotBytes = 6;

/// Bits of the rolling cycle counter carried in every slot.
inline constexpr int kCounterBits = 4;
inline constexpr std::uint8_t kCounterModulo = 1u << kCounterBits;
/// Slots of the largest sample (12 DOF: 8 slots, 64 bytes, exactly one CAN FD frame).
inline constexpr int kMaxSlots = 8;
/// The most DOF classic CAN carries: its slots are frames base + 0..3 (the identifier base + 4 is the FD frame's),
/// so 4 slots, 6 DOF. Beyond that classic CAN would need more identifiers, and its bus would not carry them anyway:
/// 6 DOF bilateral at 1 kHz is 108 % of 1 Mbit/s (docs/performance.md). CAN FD carries 1..kMaxWireDof (12).
inline constexpr int kMaxClassicDof = 6;
/// Slots of the largest classic sample.
inline constexpr int kMaxClassicSlots = 4;
/// Identifier of the FD frame relative to the direction's base identifier (classic frames use base + 0..3).
inline constexpr std::uint32_t kFdIdOffset = 4;
/// Identifiers a direction occupies: base .. base + kIdSpan - 1.
inline constexpr std::uint32_t kIdSpan = 5;

/// The signals of slot `slot` (the even or odd table; flags are listed for every even slot but only used in 0).
std::span<const SlotSignal> SlotSignals(int slot) noexcept;
/// True when `signal` of `slot` is sent for a sample of `dof` DOF.
bool SignalUsed(int slot, const SlotSignal& signal, int dof) noexcept;
/// Global DOF index of a per-DOF signal of `slot`.
int GlobalDof(int slot, const SlotSignal& signal) noexcept;
/// Slots a sample of `dof` DOF needs (1 DOF: 1, 2-3: 2, 4: 3, 5-6: 4); any dof ≥ 1 (the layout is periodic, which
/// the bus-load budget uses beyond kMaxWireDof).
int SlotCount(int dof) noexcept;
/// Bytes of slot `slot` for `dof` DOF: up to the last used signal (slot 0: and its layout marker), rounded up to
/// whole bytes.
int SlotLength(int slot, int dof) noexcept;
/// Bit of slot 0 that carries the layout marker (always 1) for `dof` DOF: the bit after its last used signal (48 for
/// 1 DOF, 62 otherwise).
int LayoutMarkerBit(int dof) noexcept;
/// Information bits of one cycle: dof·(14 + 11 + 12) + 7 flag bits + one 4-bit counter (the layout marker is
/// overhead, not information). The floor any layout of
/// this content at this resolution needs (the "theoretical minimum" of docs/can.md).
int PayloadBits(int dof) noexcept;
/// Data bytes of the FD frame for `dof` DOF (before rounding to an FD length): 8·(slots-1) + last slot length.
int FdDataBytes(int dof) noexcept;

}  // namespace teleop::proto::can
