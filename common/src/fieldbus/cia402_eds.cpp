#include "teleop/fieldbus/cia402_eds.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "teleop/error.hpp"

namespace teleop::fieldbus {

namespace dt = canopen::datatype;
namespace obj = cia402::obj;
namespace obj301 = cia402::obj301;

namespace {

enum Use : unsigned { kRead = 1, kWrite = 2, kMapRx = 4, kMapTx = 8 };

struct Need {
  std::uint16_t index;
  std::uint8_t subindex;
  std::uint16_t type;
  unsigned use;
  std::string what;
};

std::string SectionName(std::uint16_t index, std::uint8_t sub, bool is_sub) {
  return is_sub ? fmt::format("{:04X}sub{:X}", index, sub) : fmt::format("{:04X}", index);
}

std::uint16_t TypeOfBits(int bits, bool is_signed) {
  switch (bits) {
    case 8:
      return is_signed ? dt::kInteger8 : dt::kUnsigned8;
    case 16:
      return is_signed ? dt::kInteger16 : dt::kUnsigned16;
    default:
      return is_signed ? dt::kInteger32 : dt::kUnsigned32;
  }
}

/// Every object the client uses with `config`, and how.
std::vector<Need> Needs(const Cia402DriveConfig& config) {
  std::vector<Need> needs = {
      {obj301::kDeviceType, 0, dt::kUnsigned32, kRead, "device type"},
      {obj301::kErrorRegister, 0, dt::kUnsigned8, kRead, "error register"},
      {obj301::kCobIdSync, 0, dt::kUnsigned32, kWrite, "COB-ID SYNC"},
      {obj301::kCommunicationCyclePeriod, 0, dt::kUnsigned32, kWrite, "communication cycle period"},
      {obj301::kConsumerHeartbeatTime, 1, dt::kUnsigned32, kWrite, "consumer heartbeat time"},
      {obj301::kProducerHeartbeatTime, 0, dt::kUnsigned16, kWrite, "producer heartbeat time"},
      {obj301::kIdentity, 1, dt::kUnsigned32, kRead, "vendor-ID"},
      {obj::kErrorCode, 0, dt::kUnsigned16, kRead, "error code"},
      {obj::kControlword, 0, dt::kUnsigned16, kWrite | kMapRx, "controlword"},
      {obj::kStatusword, 0, dt::kUnsigned16, kRead | kMapTx, "statusword"},
      {obj::kModesOfOperation, 0, dt::kInteger8, kWrite, "modes of operation"},
      {obj::kModesOfOperationDisplay, 0, dt::kInteger8, kRead, "modes of operation display"},
      {obj::kSupportedDriveModes, 0, dt::kUnsigned32, kRead, "supported drive modes"},
      {obj::kPositionActual, 0, dt::kInteger32, kRead | kMapTx, "position actual value"},
      {obj::kVelocityActual, 0, dt::kInteger32, kRead | kMapTx, "velocity actual value"},
  };
  switch (config.mode) {
    case Cia402Mode::kCyclicSynchronousTorque:
      needs.push_back({obj::kTargetTorque, 0, dt::kInteger16, kWrite | kMapRx, "target torque (torque mode)"});
      needs.push_back({obj::kMaxTorque, 0, dt::kUnsigned16, kWrite, "max torque (torque mode)"});
      needs.push_back({obj::kRatedTorque, 0, dt::kUnsigned32, kRead, "motor rated torque (torque mode)"});
      break;
    case Cia402Mode::kCyclicSynchronousVelocity:
      needs.push_back({obj::kTargetVelocity, 0, dt::kInteger32, kWrite | kMapRx, "target velocity (velocity mode)"});
      break;
    case Cia402Mode::kCyclicSynchronousPosition:
      needs.push_back({obj::kTargetPosition, 0, dt::kInteger32, kWrite | kMapRx, "target position (position mode)"});
      break;
  }
  if (config.quick_stop_option_code) {
    needs.push_back({obj::kQuickStopOptionCode, 0, dt::kInteger16, kWrite, "quick stop option code"});
  }
  if (config.fault_reaction_option_code) {
    needs.push_back({obj::kFaultReactionOptionCode, 0, dt::kInteger16, kWrite, "fault reaction option code"});
  }
  if (config.halt_option_code) needs.push_back({obj::kHaltOptionCode, 0, dt::kInteger16, kWrite, "halt option code"});
  // Every mapped object must be mappable in its direction, with the size it is mapped with.
  auto mapped = [&](const std::vector<canopen::PdoMapping>& list, bool tpdo) {
    for (const canopen::PdoMapping& m : list) {
      for (const canopen::PdoEntry& e : m.mapped()) {
        bool known = false;
        for (Need& n : needs) {
          if (n.index == e.index && n.subindex == e.subindex) {
            n.use |= tpdo ? kMapTx : kMapRx;
            known = true;
          }
        }
        if (!known) {
          const bool is_signed = e.index == obj::kTorqueActual || e.index == obj::kTargetTorque;
          needs.push_back({e.index, e.subindex, TypeOfBits(e.bits, is_signed), tpdo ? kMapTx : kMapRx,
                           fmt::format("mapped in {}PDO{}", tpdo ? "T" : "R", m.number)});
        }
      }
    }
  };
  mapped(config.rpdos, false);
  mapped(config.tpdos, true);
  return needs;
}

/// What is wrong with `n` in `eds` (appended to `problems`).
void CheckNeed(const canopen::Eds& eds, const Cia402DriveConfig& config, const Need& n,
               std::vector<std::string>& problems) {
  const std::string& file = eds.file();
  const canopen::EdsEntry* e = eds.Find(n.index, n.subindex);
  if (e == nullptr) {
    const bool array = eds.Has(n.index) && n.subindex != 0;
    problems.push_back(
        array ? fmt::format("{}: no section [{}] ({:04X}:{:02X}, {}): the object has no sub-index {}", file,
                            SectionName(n.index, n.subindex, true), n.index, n.subindex, n.what, n.subindex)
              : fmt::format("{}: no section [{}] or [{}] (object 0x{:04X}, {}), which the client {}", file,
                            SectionName(n.index, 0, false), SectionName(n.index, n.subindex, true), n.index, n.what,
                            (n.use & kWrite) != 0              ? "writes"
                            : (n.use & (kMapRx | kMapTx)) != 0 ? "maps"
                                                               : "reads"));
    return;
  }
  if (!e->data_type) {
    problems.push_back(fmt::format("{}: [{}] has no DataType ({})", file, e->section, n.what));
  } else if (*e->data_type != n.type) {
    problems.push_back(fmt::format("{}: [{}] DataType is 0x{:04X} ({}), the client uses {} (0x{:04X}): {}", file,
                                   e->section, *e->data_type, canopen::DataTypeName(*e->data_type),
                                   canopen::DataTypeName(n.type), n.type, n.what));
  }
  if ((n.use & kRead) != 0 && !e->readable()) {
    problems.push_back(
        fmt::format("{}: [{}] AccessType is '{}', the client reads it: {}", file, e->section, e->access, n.what));
  }
  if (((n.use & kWrite) != 0 || (n.use & kMapRx) != 0) && !e->writable()) {
    problems.push_back(
        fmt::format("{}: [{}] AccessType is '{}', the client writes it: {}", file, e->section, e->access, n.what));
  }
  if ((n.use & kMapTx) != 0 && (n.use & kRead) == 0 && !e->readable()) {
    problems.push_back(
        fmt::format("{}: [{}] AccessType is '{}', a TPDO cannot carry it: {}", file, e->section, e->access, n.what));
  }
  bool is_mapped = false;
  for (const auto* list : {&config.rpdos, &config.tpdos}) {
    for (const canopen::PdoMapping& m : *list) {
      for (const canopen::PdoEntry& pe : m.mapped()) is_mapped |= pe.index == n.index && pe.subindex == n.subindex;
    }
  }
  if (is_mapped && !e->pdo_mapping) {
    problems.push_back(
        fmt::format("{}: [{}] PDOMapping is 0, the configuration maps it: {}", file, e->section, n.what));
  }
}

/// The configured mode in the EDS's supported modes; the PDO counts and mapping capacity.
void CheckModeAndPdos(const canopen::Eds& eds, const Cia402DriveConfig& config, std::vector<std::string>& problems) {
  const std::string& file = eds.file();
  // The mode in the EDS's supported drive modes (its DefaultValue, where the EDS gives one).
  const auto mode = static_cast<std::int8_t>(config.mode);
  if (const canopen::EdsEntry* e = eds.Find(obj::kSupportedDriveModes, 0); e != nullptr && !e->default_value.empty()) {
    const std::uint32_t modes = eds.DefaultValue(obj::kSupportedDriveModes, 0, config.node_id).value_or(0);
    if ((modes & cia402::SupportedModeBit(mode)) == 0) {
      problems.push_back(fmt::format("{}: [{}] DefaultValue 0x{:08X} lacks {} (bit {}), the configured mode", file,
                                     e->section, modes, ToString(config.mode), mode - 1));
    }
  }
  // PDO counts and mapping capacity.
  auto capacity = [&](const std::vector<canopen::PdoMapping>& list, bool tpdo) {
    const int count = tpdo ? eds.tx_pdo_count() : eds.rx_pdo_count();
    for (const canopen::PdoMapping& m : list) {
      if (m.number > count) {
        problems.push_back(fmt::format("{}: [DeviceInfo] {} is {}, the configuration uses {}PDO{}", file,
                                       tpdo ? "NrOfTXPDO" : "NrOfRXPDO", count, tpdo ? "T" : "R", m.number));
        continue;
      }
      const auto map = static_cast<std::uint16_t>((tpdo ? obj301::kTpdoMapping : obj301::kRpdoMapping) + m.number - 1);
      const int entries = eds.MappingCapacity(map);
      if (m.entry_count > entries) {
        problems.push_back(fmt::format("{}: [{:04X}] maps at most {} objects ({:04X}sub1..sub{:X}), {}PDO{} has {}",
                                       file, map, entries, map, entries, tpdo ? "T" : "R", m.number, m.entry_count));
      }
    }
  };
  capacity(config.rpdos, false);
  capacity(config.tpdos, true);
}

}  // namespace

std::vector<std::string> CheckAgainstEds(const canopen::Eds& eds, const Cia402DriveConfig& config) {
  std::vector<std::string> problems;
  for (const Need& n : Needs(config)) CheckNeed(eds, config, n, problems);
  CheckModeAndPdos(eds, config, problems);
  return problems;
}

void ApplyEdsDefaults(const canopen::Eds& eds, Cia402DriveConfig& config) {
  auto apply = [&](std::vector<canopen::PdoMapping>& list, bool tpdo) {
    for (canopen::PdoMapping& m : list) {
      if (m.cob_id != 0 || m.number < 1 || m.number > 4) continue;
      const auto comm =
          static_cast<std::uint16_t>((tpdo ? obj301::kTpdoCommunication : obj301::kRpdoCommunication) + m.number - 1);
      if (const auto v = eds.DefaultValue(comm, 1, config.node_id)) m.cob_id = *v & 0x7FFu;
    }
  };
  apply(config.rpdos, false);
  apply(config.tpdos, true);
}

void ApplyEds(Cia402DriveConfig& config) {
  if (config.eds_file.empty()) return;
  const canopen::Eds eds = canopen::Eds::Load(config.eds_file);
  ApplyEdsDefaults(eds, config);
  const std::vector<std::string> problems = CheckAgainstEds(eds, config);
  if (problems.empty()) return;
  std::string text =
      fmt::format("CiA 402 drive node {}: the EDS does not fit the configuration ({} problem{}):", config.node_id,
                  problems.size(), problems.size() == 1 ? "" : "s");
  for (const std::string& p : problems) text += "\n  " + p;
  throw Error(text);
}

}  // namespace teleop::fieldbus
