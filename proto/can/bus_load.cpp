#include "teleop/proto/can/bus_load.hpp"

#include <algorithm>
#include <array>

#include "teleop/proto/can/can_frame.hpp"
#include "teleop/proto/can/frame_layout.hpp"

namespace teleop::proto::can {

namespace {

// Frame lengths a frame of each kind may have (bytes); classic frames any of 1..8.
constexpr std::array<std::size_t, 15> kFdLengths{1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
constexpr std::size_t kMaxBudgetBytes = 1024;

struct Cost {
  double time_s = 0;
  int bits = 0;
};

int Bits(bool fd, bool extended, std::size_t bytes) noexcept {
  if (!fd) return ClassicFrameBits(extended, bytes);
  const FdFrameBits b = FdFrameBitsWorstCase(extended, bytes);
  return b.nominal + b.data;
}

// The cheapest set of frames (same kind, identifier width and rates) whose data fields hold `bytes` bytes: a
// small dynamic programme over the byte count, since an FD frame's time is a step function of its length.
Cost CheapestFrames(bool fd, bool brs, bool extended, std::size_t bytes, const CanBitrates& rates) noexcept {
  std::array<Cost, kMaxBudgetBytes + 1> best{};
  bytes = std::min(bytes, kMaxBudgetBytes);
  for (std::size_t n = 1; n <= bytes; ++n) {
    best[n].time_s = 1e300;
    for (const std::size_t len : kFdLengths) {
      if (!fd && len > kClassicMaxDataBytes) break;
      const Cost& rest = best[n > len ? n - len : 0];
      const double t = FrameTime_s(fd, brs, extended, len, rates) + rest.time_s;
      if (t < best[n].time_s) best[n] = Cost{t, Bits(fd, extended, len) + rest.bits};
    }
  }
  return best[bytes];
}

}  // namespace

int ClassicFrameBits(bool extended, std::size_t data_bytes) noexcept {
  return (extended ? 80 : 55) + 10 * static_cast<int>(std::min(data_bytes, kClassicMaxDataBytes));
}

FdFrameBits FdFrameBitsWorstCase(bool extended, std::size_t data_bytes) noexcept {
  // Nominal-rate head: SOF, identifier, RRS/SRR, IDE, [18 extension bits, RRS], FDF, res, BRS.
  const int head = extended ? 1 + 11 + 1 + 1 + 18 + 1 + 1 + 1 + 1 : 1 + 11 + 1 + 1 + 1 + 1 + 1;
  // Data-rate part covered by dynamic stuffing: ESI, DLC, data.
  const int body = 1 + 4 + 8 * static_cast<int>(data_bytes);
  // Worst case: a stuff bit after the first 5 bits and then after every 4 (alternating runs).
  const int head_stuff = (head - 1) / 4;
  const int body_stuff = (head + body - 1) / 4 - head_stuff;
  const int crc = data_bytes <= 16 ? 17 : 21;
  const int stuff_count = 4;                            // 3-bit Gray-coded count + parity
  const int fixed_stuff = (stuff_count + crc + 3) / 4;  // one before the stuff count, then every 4 bits
  // Nominal-rate tail: CRC delimiter (the switch-back point), ACK slot, ACK delimiter, EOF 7, intermission 3.
  const int tail = 1 + 1 + 1 + 7 + 3;
  return FdFrameBits{head + head_stuff + tail, body + body_stuff + stuff_count + crc + fixed_stuff};
}

double FrameTime_s(bool fd, bool brs, bool extended, std::size_t data_bytes, const CanBitrates& rates) noexcept {
  if (!fd) return static_cast<double>(ClassicFrameBits(extended, data_bytes)) / rates.nominal_bit_per_s;
  const FdFrameBits b = FdFrameBitsWorstCase(extended, data_bytes);
  const double data_rate = brs ? rates.data_bit_per_s : rates.nominal_bit_per_s;
  return static_cast<double>(b.nominal) / rates.nominal_bit_per_s + static_cast<double>(b.data) / data_rate;
}

BusLoad ComputeBusLoad(const CanWireFormat& format, const CanBitrates& rates, double rate_hz) noexcept {
  BusLoad r{};
  const int dof = format.dof;
  if (dof < 1 || !(rate_hz > 0.0) || !(rates.nominal_bit_per_s > 0.0) || !(rates.data_bit_per_s > 0.0)) return r;
  r.dof = dof;
  const int slots = SlotCount(dof);
  const bool fd = format.fd;
  const bool brs = format.fd && format.brs;
  auto add_frame = [&](std::size_t bytes) {
    ++r.frames_per_cycle;
    r.data_bytes_per_cycle += static_cast<int>(bytes);
    r.wire_bits_per_cycle += Bits(fd, format.extended_id, bytes);
    const double time_s = FrameTime_s(fd, brs, format.extended_id, bytes, rates);
    r.wire_time_per_cycle_s += time_s;
    r.longest_frame_s = std::max(r.longest_frame_s, time_s);
  };
  if (!fd) {
    for (int k = 0; k < slots; ++k) add_frame(static_cast<std::size_t>(SlotLength(k, dof)));
  } else {
    // At most 8 slots (64 bytes) per FD frame; kMaxWireDof needs one frame, larger counts extrapolate.
    for (int first = 0; first < slots; first += 8) {
      const int last = std::min(slots, first + 8) - 1;
      const int bytes = 8 * (last - first) + SlotLength(last, dof);
      add_frame(RoundUpToFdLength(static_cast<std::size_t>(bytes)));
    }
  }
  r.payload_bits = PayloadBits(dof);
  const Cost min =
      CheapestFrames(fd, brs, format.extended_id, static_cast<std::size_t>((r.payload_bits + 7) / 8), rates);
  r.minimum_bits_per_cycle = min.bits;
  r.minimum_time_per_cycle_s = min.time_s;
  r.overhead = min.time_s > 0 ? r.wire_time_per_cycle_s / min.time_s : 0.0;
  r.load = 2.0 * r.wire_time_per_cycle_s * rate_hz;
  r.cycle_complete_s = r.longest_frame_s + r.wire_time_per_cycle_s;
  return r;
}

int MaxDofWithinLoad(CanWireFormat format, const CanBitrates& rates, double rate_hz, double max_load,
                     int max_dof) noexcept {
  int best = 0;
  for (int dof = 1; dof <= max_dof; ++dof) {
    format.dof = dof;
    if (ComputeBusLoad(format, rates, rate_hz).load <= max_load) best = dof;
  }
  return best;
}

}  // namespace teleop::proto::can
