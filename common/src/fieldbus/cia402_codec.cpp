#include "teleop/fieldbus/cia402_codec.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "teleop/fieldbus/cia402_state_machine.hpp"

namespace teleop::fieldbus {

using canopen::PdoEntry;
using canopen::PdoMapping;
using proto::can::CanFrame;
namespace obj = cia402::obj;

namespace {

std::int32_t RoundToI32(double x) noexcept {
  return static_cast<std::int32_t>(std::clamp<double>(std::round(x), -2147483647.0, 2147483647.0));
}

std::size_t At(int i) noexcept { return static_cast<std::size_t>(i); }

/// Where `index`:0 sits in the first `count` of `list`; `error` says when it is mapped twice or with other than
/// `bits` bits.
Cia402PdoSlot Find(const std::array<PdoMapping, 4>& list, int count, std::uint16_t index, std::uint8_t bits,
                   std::string& error) {
  Cia402PdoSlot slot{};
  for (int p = 0; p < count; ++p) {
    const PdoMapping& m = list[At(p)];
    for (int e = 0; e < m.entry_count; ++e) {
      const PdoEntry& entry = m.entries[At(e)];
      if (entry.index != index || entry.subindex != 0) continue;
      if (entry.bits != bits && error.empty()) {
        error = fmt::format("object 0x{:04X} is {} bits, mapped with {}", index, bits, entry.bits);
      }
      if (slot.mapped() && error.empty()) error = fmt::format("object 0x{:04X} mapped twice", index);
      slot = Cia402PdoSlot{p, e};
    }
  }
  return slot;
}

/// Copies `list` into `out`, checking each mapping; the error, or empty.
std::string Take(std::span<const PdoMapping> list, std::array<PdoMapping, 4>& out, int& count, bool tpdo) {
  const char* what = tpdo ? "tpdos" : "rpdos";
  if (list.empty() || list.size() > 4) return fmt::format("{}: 1..4 PDOs", what);
  for (const PdoMapping& m : list) {
    const canopen::PdoMappingStatus st = canopen::CheckPdoMapping(m);
    if (st != canopen::PdoMappingStatus::kOk)
      return fmt::format("{} PDO {}: {}", what, m.number, canopen::ToString(st));
    if (m.transmission_type > 240) {
      return fmt::format("{} PDO {}: cyclic synchronous mode needs a synchronous transmission type (1..240)", what,
                         m.number);
    }
    for (int k = 0; k < count; ++k) {
      if (out[At(k)].number == m.number) return fmt::format("{}: PDO {} twice", what, m.number);
    }
    out[At(count++)] = m;
  }
  return {};
}

/// The mode's target in the RPDOs; the error when the controlword or the target is missing.
std::string FindTarget(Cia402Mode mode, Cia402PdoLayout& l, std::string& error) {
  switch (mode) {
    case Cia402Mode::kCyclicSynchronousTorque:
      l.target = Find(l.rpdo, l.rpdo_count, obj::kTargetTorque, 16, error);
      if (!l.controlword.mapped() || !l.target.mapped()) {
        return "rpdos must map the controlword 0x6040 and the target torque 0x6071 (16 bits each)";
      }
      break;
    case Cia402Mode::kCyclicSynchronousVelocity:
      l.target = Find(l.rpdo, l.rpdo_count, obj::kTargetVelocity, 32, error);
      if (!l.controlword.mapped() || !l.target.mapped()) {
        return "velocity mode: rpdos must map the controlword 0x6040 (16 bits) and the target velocity 0x60FF (32 "
               "bits)";
      }
      break;
    case Cia402Mode::kCyclicSynchronousPosition:
      l.target = Find(l.rpdo, l.rpdo_count, obj::kTargetPosition, 32, error);
      if (!l.controlword.mapped() || !l.target.mapped()) {
        return "position mode: rpdos must map the controlword 0x6040 (16 bits) and the target position 0x607A (32 "
               "bits)";
      }
      break;
  }
  return {};
}

}  // namespace

namespace cia402_codec {

std::int16_t TorqueToPerMille(double torque_Nm, const Cia402Scaling& s) noexcept {
  const double per_mille = std::round(s.sign * torque_Nm / s.rated_torque_Nm * 1000.0);
  return static_cast<std::int16_t>(std::isfinite(per_mille) ? std::clamp(per_mille, -32768.0, 32767.0) : 0.0);
}
double TorqueFromPerMille(std::int16_t per_mille, const Cia402Scaling& s) noexcept {
  return s.sign * s.rated_torque_Nm * 1e-3 * per_mille;
}
std::int32_t VelocityToUnits(double velocity_rad_per_s, const Cia402Scaling& s) noexcept {
  return RoundToI32(s.sign * velocity_rad_per_s / s.velocity_rad_per_s_per_unit);
}
double VelocityFromUnits(std::int32_t units, const Cia402Scaling& s) noexcept {
  return s.sign * s.velocity_rad_per_s_per_unit * units;
}
std::int32_t PositionToCounts(double position_rad, const Cia402Scaling& s) noexcept {
  return RoundToI32(s.sign * position_rad / s.position_rad_per_count);
}
double PositionFromCounts(std::int32_t counts, const Cia402Scaling& s) noexcept {
  return s.sign * s.position_rad_per_count * counts;
}

bool EncodeRpdos(const Cia402PdoLayout& layout, std::uint16_t controlword, std::uint32_t target_raw,
                 std::span<CanFrame, 4> frames) noexcept {
  Cia402PdoValues values{};
  values[At(layout.controlword.pdo)][At(layout.controlword.entry)] = controlword;
  values[At(layout.target.pdo)][At(layout.target.entry)] = target_raw;
  for (int p = 0; p < layout.rpdo_count; ++p) {
    const PdoMapping& m = layout.rpdo[At(p)];
    if (!canopen::PackPdo(m, layout.rpdo_cob[At(p)],
                          std::span<const std::uint32_t>(values[At(p)].data(), At(m.entry_count)), frames[At(p)])) {
      return false;
    }
  }
  return true;
}

Cia402TpdoResult DecodeTpdo(const Cia402PdoLayout& layout, const CanFrame& frame, Cia402PdoValues& values,
                            int& pdo) noexcept {
  if (frame.error || frame.extended || frame.fd || frame.remote) return Cia402TpdoResult::kNotTpdo;
  for (int p = 0; p < layout.tpdo_count; ++p) {
    if (frame.id != layout.tpdo_cob[At(p)]) continue;
    const PdoMapping& m = layout.tpdo[At(p)];
    std::array<std::uint32_t, canopen::kMaxPdoEntries> unpacked{};
    if (!canopen::UnpackPdo(m, frame, std::span<std::uint32_t>(unpacked.data(), At(m.entry_count)))) {
      return Cia402TpdoResult::kRejected;
    }
    values[At(p)] = unpacked;
    pdo = p;
    return Cia402TpdoResult::kStored;
  }
  return Cia402TpdoResult::kNotTpdo;
}

std::uint16_t Statusword(const Cia402PdoLayout& layout, const Cia402PdoValues& values) noexcept {
  return static_cast<std::uint16_t>(values[At(layout.statusword.pdo)][At(layout.statusword.entry)]);
}

Cia402Measured Measured(const Cia402PdoLayout& layout, const Cia402PdoValues& values,
                        const Cia402Scaling& scaling) noexcept {
  const auto raw = [&](const Cia402PdoSlot& s) { return values[At(s.pdo)][At(s.entry)]; };
  Cia402Measured m;
  m.position_rad = PositionFromCounts(canopen::SignExtend(raw(layout.position), 32), scaling);
  m.velocity_rad_per_s = VelocityFromUnits(canopen::SignExtend(raw(layout.velocity), 32), scaling);
  m.torque_mapped = layout.torque.mapped();
  if (m.torque_mapped) {
    m.torque_Nm = TorqueFromPerMille(static_cast<std::int16_t>(canopen::SignExtend(raw(layout.torque), 16)), scaling);
  }
  return m;
}

}  // namespace cia402_codec

std::string Cia402PdoLayout::Make(Cia402Mode mode, std::span<const PdoMapping> rpdos, std::span<const PdoMapping> tpdos,
                                  std::uint8_t node_id, Cia402PdoLayout& out) {
  Cia402PdoLayout l;
  std::string error = Take(rpdos, l.rpdo, l.rpdo_count, false);
  if (error.empty()) error = Take(tpdos, l.tpdo, l.tpdo_count, true);
  if (!error.empty()) return error;
  l.controlword = Find(l.rpdo, l.rpdo_count, obj::kControlword, 16, error);
  l.statusword = Find(l.tpdo, l.tpdo_count, obj::kStatusword, 16, error);
  l.position = Find(l.tpdo, l.tpdo_count, obj::kPositionActual, 32, error);
  l.velocity = Find(l.tpdo, l.tpdo_count, obj::kVelocityActual, 32, error);
  l.torque = Find(l.tpdo, l.tpdo_count, obj::kTorqueActual, 16, error);
  if (mode != Cia402Mode::kCyclicSynchronousTorque) (void)Find(l.rpdo, l.rpdo_count, obj::kTargetTorque, 16, error);
  std::string missing = FindTarget(mode, l, error);
  if (!error.empty()) return error;
  if (!missing.empty()) return missing;
  if (!l.statusword.mapped() || !l.position.mapped() || !l.velocity.mapped()) {
    return "tpdos must map the statusword 0x6041 (16 bits), position actual 0x6064 and velocity actual 0x606C (32 "
           "bits each)";
  }
  for (int p = 0; p < l.rpdo_count; ++p) l.rpdo_cob[At(p)] = canopen::PdoCobId(l.rpdo[At(p)], false, node_id);
  for (int p = 0; p < l.tpdo_count; ++p) l.tpdo_cob[At(p)] = canopen::PdoCobId(l.tpdo[At(p)], true, node_id);
  const int n = l.tpdo_count + l.rpdo_count;
  const auto cob = [&](int a) { return a < l.tpdo_count ? l.tpdo_cob[At(a)] : l.rpdo_cob[At(a - l.tpdo_count)]; };
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      if (cob(a) == cob(b)) return fmt::format("PDO COB-ID 0x{:03X} used twice", cob(a));
    }
  }
  out = l;
  return {};
}

}  // namespace teleop::fieldbus
