#pragma once

#include "teleop/device/device.hpp"

namespace teleop::device {

/// The cycle's one bus exchange, the part of the device seam a fieldbus backend implements beside Device (like
/// ros2_control's separate interfaces for what only some hardware has). The node calls Exchange() once per cycle,
/// before Device::Read(), on a device that has it (ExchangeOf); a backend without a bus does not implement it.
///
/// In Exchange() a backend takes in what the bus brought since the last one (the drives' TPDOs, a CAN sensor's
/// frames, the newest values of a slow bus's I/O thread) and sends the cycle's SYNC, on which the drives apply the
/// RPDOs the previous cycle's Write()/Update() queued. They are queued a period ahead because the SYNC (COB-ID 0x080)
/// would win the arbitration against an RPDO queued beside it, and every drive must apply on the same SYNC. Read()
/// then only interprets what Exchange() took in: it does no bus I/O, so reading twice sends nothing. A failed
/// exchange is a fault named after what failed (the SYNC, a drive, the sensor, the amplifier), reported by the next
/// Read(). Real-time: no allocation, no locks, no blocking, no exceptions, no logging.
class BusExchange {
 public:
  virtual ~BusExchange() = default;
  BusExchange() = default;
  BusExchange(const BusExchange&) = delete;
  BusExchange& operator=(const BusExchange&) = delete;

  /// The cycle's bus exchange, once per cycle before Read(). Never blocks.
  virtual void Exchange() noexcept = 0;
};

/// The device's bus exchange, or nullptr when it has none (set-up: the node asks once, at construction).
inline BusExchange* ExchangeOf(Device& device) noexcept { return dynamic_cast<BusExchange*>(&device); }

}  // namespace teleop::device
