#pragma once

#include <cstddef>

#include "teleop/proto/can/wire_format.hpp"

namespace teleop::proto::can {

/// Bit rates of the bus.
struct CanBitrates {
  double nominal_bit_per_s = 1'000'000.0;  ///< Arbitration (and classic) bit rate.
  double data_bit_per_s = 5'000'000.0;     ///< FD data phase with bit-rate switch.
};

/// Bits of a classic data frame with worst-case bit stuffing, including the 3-bit intermission:
/// 55 + 10·s (11-bit identifier) or 80 + 10·s (29-bit), s = data bytes (0..8).
int ClassicFrameBits(bool extended, std::size_t data_bytes) noexcept;

/// Bits of a CAN FD frame with worst-case stuffing, split into the part sent at the nominal rate (arbitration,
/// ACK, EOF, intermission) and the part at the data rate (ESI, DLC, data, stuff count, CRC and fixed stuff bits).
/// Without bit-rate switch both parts run at the nominal rate. docs/can.md derives every term.
struct FdFrameBits {
  int nominal = 0;
  int data = 0;
};
FdFrameBits FdFrameBitsWorstCase(bool extended, std::size_t data_bytes) noexcept;

/// Seconds one frame of `data_bytes` occupies the bus (worst-case stuffing).
double FrameTime_s(bool fd, bool brs, bool extended, std::size_t data_bytes, const CanBitrates& rates) noexcept;

/// The bus-load budget of a bilateral link: both directions send one cycle at `rate_hz`.
struct BusLoad {
  int dof = 0;
  int frames_per_cycle = 0;          ///< Per direction.
  int data_bytes_per_cycle = 0;      ///< Per direction, as sent (incl. FD padding).
  int wire_bits_per_cycle = 0;       ///< Per direction, worst-case stuffing, both bit-rate phases added.
  double wire_time_per_cycle_s = 0;  ///< Per direction.
  int payload_bits = 0;              ///< PayloadBits(dof), per direction.
  int minimum_bits_per_cycle = 0;    ///< Cheapest frames holding the payload (same ID format, rates, stuffing).
  double minimum_time_per_cycle_s = 0;
  double overhead = 0;         ///< wire_time / minimum_time (≥ 1).
  double load = 0;             ///< Fraction of bus time, both directions: 2·wire_time·rate.
  double longest_frame_s = 0;  ///< Per direction: the longest frame of a cycle.
  /// Worst case from queueing a cycle until the peer holds all of it: one frame of the other direction already on
  /// the bus (the longest of the same layout; arbitration does not preempt it) plus this cycle's frames. What a
  /// triggered slave waits on the bus for the master's sample (docs/can.md, "Phase-locked cycles over CAN").
  double cycle_complete_s = 0;
};

/// Computes the budget for `format` at `rate_hz`. Valid for any dof ≥ 1 (beyond kMaxWireDof it extrapolates the
/// periodic layout, with FD frames of at most 8 slots); dof < 1 or rate ≤ 0 gives a zeroed result.
BusLoad ComputeBusLoad(const CanWireFormat& format, const CanBitrates& rates, double rate_hz) noexcept;

/// Largest dof (1..max_dof) whose load stays ≤ `max_load` at `rate_hz`; 0 when not even 1 DOF fits.
int MaxDofWithinLoad(CanWireFormat format, const CanBitrates& rates, double rate_hz, double max_load,
                     int max_dof) noexcept;

}  // namespace teleop::proto::can
