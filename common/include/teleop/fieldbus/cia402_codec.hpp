#pragma once

// The CiA 402 cycle's bytes (docs/cia402.md): SI values <-> drive units <-> PDO frames, for one drive's PDO layout.
// Pure, as moteus keeps `moteus_protocol.h` apart from its transport: no I/O, no clock, no allocation, no
// exceptions; golden-byte tested (tests/fieldbus/cia402_codec_test.cpp). The set-up (Cia402Drive::Configure) writes
// the layout to the drive; the cycle (Cia402Drive::Read/Write*) moves frames through it.

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"

namespace teleop::fieldbus {

/// From the drive's units to SI (CiA 402: torque in per mille of the rated torque 0x6076; position and velocity in
/// the drive's position/velocity units, commonly encoder counts and counts/s).
struct Cia402Scaling {
  double rated_torque_Nm = 1.0;                       ///< 0x6076 (read back from the drive and checked at configure).
  double position_rad_per_count = 1.0 / 4096.0;       ///< 0x6064 unit.
  double velocity_rad_per_s_per_unit = 1.0 / 4096.0;  ///< 0x606C unit.
  double sign = 1.0;  ///< -1 when the drive's positive direction is the joint's negative one.
};

/// The cyclic synchronous modes of CiA 402 (0x6060): the target the RPDO carries each cycle.
enum class Cia402Mode : std::int8_t {
  kCyclicSynchronousPosition = 8,  ///< 0x607A target position; the drive closes position and velocity loops.
  kCyclicSynchronousVelocity = 9,  ///< 0x60FF target velocity; the drive closes the velocity loop.
  kCyclicSynchronousTorque = 10,   ///< 0x6071 target torque.
};

namespace cia402_codec {

// ---- SI <-> drive units (rounded to nearest, saturated at the object's range) ----
/// 0x6071 / 0x6077: per mille of the rated torque, INTEGER16.
std::int16_t TorqueToPerMille(double torque_Nm, const Cia402Scaling& s) noexcept;
double TorqueFromPerMille(std::int16_t per_mille, const Cia402Scaling& s) noexcept;
/// 0x60FF / 0x606C: velocity units, INTEGER32.
std::int32_t VelocityToUnits(double velocity_rad_per_s, const Cia402Scaling& s) noexcept;
double VelocityFromUnits(std::int32_t units, const Cia402Scaling& s) noexcept;
/// 0x607A / 0x6064: position units, INTEGER32.
std::int32_t PositionToCounts(double position_rad, const Cia402Scaling& s) noexcept;
double PositionFromCounts(std::int32_t counts, const Cia402Scaling& s) noexcept;

}  // namespace cia402_codec

/// Where a cycle object sits: PDO slot (0..3 of the layout's RPDOs or TPDOs) and entry; pdo < 0 when not mapped.
struct Cia402PdoSlot {
  int pdo = -1;
  int entry = -1;
  bool mapped() const noexcept { return pdo >= 0; }
};

/// The raw values of the entries of up to four PDOs (zero-extended; one array per PDO slot).
using Cia402PdoValues = std::array<std::array<std::uint32_t, canopen::kMaxPdoEntries>, 4>;

/// One drive's PDO layout: the mappings, their COB-IDs, and where the cycle's objects sit.
struct Cia402PdoLayout {
  std::array<canopen::PdoMapping, 4> rpdo{};
  std::array<canopen::PdoMapping, 4> tpdo{};
  std::array<std::uint32_t, 4> rpdo_cob{};
  std::array<std::uint32_t, 4> tpdo_cob{};
  int rpdo_count = 0;
  int tpdo_count = 0;
  Cia402PdoSlot controlword{}, target{};                         ///< RPDO: 0x6040 and the mode's target.
  Cia402PdoSlot statusword{}, position{}, velocity{}, torque{};  ///< TPDO: 0x6041, 0x6064, 0x606C, 0x6077.

  /// The layout of `rpdos` / `tpdos` for `mode` on node `node_id`; empty string when usable, else what is wrong
  /// (a bad mapping, a PDO twice, an object mapped twice or with the wrong size, the mode's target or a read
  /// object missing, a COB-ID used twice).
  static std::string Make(Cia402Mode mode, std::span<const canopen::PdoMapping> rpdos,
                          std::span<const canopen::PdoMapping> tpdos, std::uint8_t node_id, Cia402PdoLayout& out);
};

/// What one received frame was for the layout.
enum class Cia402TpdoResult : std::uint8_t {
  kNotTpdo,   ///< Not one of the layout's TPDOs (another node's frame, an extended or FD frame).
  kRejected,  ///< A TPDO's COB-ID with the wrong length for its mapping: nothing stored.
  kStored,    ///< Its values stored in `values[pdo]`.
};

/// The measured values in SI (0x6064, 0x606C, 0x6077 when mapped).
struct Cia402Measured {
  double position_rad = 0.0;
  double velocity_rad_per_s = 0.0;
  double torque_Nm = 0.0;  ///< 0 when 0x6077 is not mapped (torque_mapped false).
  bool torque_mapped = false;
};

namespace cia402_codec {

/// Packs the controlword and the mode's raw target into the layout's RPDOs (other mapped entries 0): frames[0 ..
/// rpdo_count). False when a mapping does not pack (never for a layout Make accepted).
[[nodiscard]] bool EncodeRpdos(const Cia402PdoLayout& layout, std::uint16_t controlword, std::uint32_t target_raw,
                               std::span<proto::can::CanFrame, 4> frames) noexcept;
/// Unpacks `frame` into `values[pdo]` when it is one of the layout's TPDOs.
[[nodiscard]] Cia402TpdoResult DecodeTpdo(const Cia402PdoLayout& layout, const proto::can::CanFrame& frame,
                                          Cia402PdoValues& values, int& pdo) noexcept;
/// 0x6041 from the TPDO values.
std::uint16_t Statusword(const Cia402PdoLayout& layout, const Cia402PdoValues& values) noexcept;
/// Position, velocity and (when mapped) torque in SI from the TPDO values.
Cia402Measured Measured(const Cia402PdoLayout& layout, const Cia402PdoValues& values,
                        const Cia402Scaling& scaling) noexcept;

}  // namespace cia402_codec
}  // namespace teleop::fieldbus
