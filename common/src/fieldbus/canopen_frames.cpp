#include "teleop/fieldbus/canopen_frames.hpp"

namespace teleop::fieldbus::canopen {

namespace {

CanFrame Classic(std::uint32_t id, std::uint8_t len) noexcept {
  CanFrame f{};
  f.id = id;
  f.len = len;
  return f;
}

bool IsClassicData(const CanFrame& f) noexcept { return !f.error && !f.fd && !f.extended && !f.remote; }

}  // namespace

const char* ToString(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::kStart:
      return "start";
    case NmtCommand::kStop:
      return "stop";
    case NmtCommand::kEnterPreOperational:
      return "enter pre-operational";
    case NmtCommand::kResetNode:
      return "reset node";
    case NmtCommand::kResetCommunication:
      return "reset communication";
  }
  return "invalid";
}

const char* ToString(NmtState state) noexcept {
  switch (state) {
    case NmtState::kBootUp:
      return "boot-up";
    case NmtState::kStopped:
      return "stopped";
    case NmtState::kOperational:
      return "operational";
    case NmtState::kPreOperational:
      return "pre-operational";
  }
  return "invalid";
}

CanFrame EncodeNmt(NmtCommand command, std::uint8_t node_id) noexcept {
  CanFrame f = Classic(cob::kNmt, 2);
  f.data[0] = static_cast<std::uint8_t>(command);
  f.data[1] = node_id;
  return f;
}

bool DecodeNmt(const CanFrame& frame, NmtCommand& command, std::uint8_t& node_id) noexcept {
  if (!IsClassicData(frame) || frame.id != cob::kNmt || frame.len != 2) return false;
  const std::uint8_t cs = frame.data[0];
  if (cs != 0x01 && cs != 0x02 && cs != 0x80 && cs != 0x81 && cs != 0x82) return false;
  if (frame.data[1] > kMaxNodeId) return false;
  command = static_cast<NmtCommand>(cs);
  node_id = frame.data[1];
  return true;
}

CanFrame EncodeHeartbeat(std::uint8_t node_id, NmtState state) noexcept {
  CanFrame f = Classic(cob::kHeartbeat + node_id, 1);
  f.data[0] = static_cast<std::uint8_t>(state);
  return f;
}

bool DecodeHeartbeat(const CanFrame& frame, std::uint8_t& node_id, NmtState& state) noexcept {
  if (!IsClassicData(frame) || frame.len != 1) return false;
  if (frame.id <= cob::kHeartbeat || frame.id > cob::kHeartbeat + kMaxNodeId) return false;
  const std::uint8_t s = frame.data[0] & 0x7Fu;  // bit 7: node guarding toggle, 0 with heartbeat
  if (s != 0x00 && s != 0x04 && s != 0x05 && s != 0x7F) return false;
  node_id = static_cast<std::uint8_t>(frame.id - cob::kHeartbeat);
  state = static_cast<NmtState>(s);
  return true;
}

CanFrame EncodeSync(std::uint32_t cob_id) noexcept { return Classic(cob_id & 0x7FFu, 0); }

CanFrame EncodeSync(std::uint32_t cob_id, std::uint8_t counter) noexcept {
  CanFrame f = Classic(cob_id & 0x7FFu, 1);
  f.data[0] = counter;
  return f;
}

bool DecodeSync(const CanFrame& frame, std::uint32_t cob_id, std::uint8_t& counter) noexcept {
  if (!IsClassicData(frame) || frame.id != (cob_id & 0x7FFu) || frame.len > 1) return false;
  counter = frame.len == 1 ? frame.data[0] : 0;
  return true;
}

CanFrame EncodeEmergency(std::uint8_t node_id, const Emergency& emergency) noexcept {
  CanFrame f = Classic(cob::kEmcy + node_id, 8);
  f.data[0] = static_cast<std::uint8_t>(emergency.error_code);
  f.data[1] = static_cast<std::uint8_t>(emergency.error_code >> 8);
  f.data[2] = emergency.error_register;
  for (std::size_t i = 0; i < emergency.manufacturer.size(); ++i) f.data[3 + i] = emergency.manufacturer[i];
  return f;
}

bool DecodeEmergency(const CanFrame& frame, std::uint8_t& node_id, Emergency& emergency) noexcept {
  if (!IsClassicData(frame) || frame.len != 8) return false;
  if (frame.id <= cob::kEmcy || frame.id > cob::kEmcy + kMaxNodeId) return false;
  node_id = static_cast<std::uint8_t>(frame.id - cob::kEmcy);
  emergency.error_code = static_cast<std::uint16_t>(frame.data[0] | frame.data[1] << 8);
  emergency.error_register = frame.data[2];
  for (std::size_t i = 0; i < emergency.manufacturer.size(); ++i) emergency.manufacturer[i] = frame.data[3 + i];
  return true;
}

const char* DescribeEmergencyCode(std::uint16_t error_code) noexcept {
  if (error_code == 0x0000) return "error reset or no error";
  if (error_code == emcy::kHeartbeatError) return "heartbeat/life guard error";
  if (error_code == emcy::kPdoLength) return "PDO not processed due to length error";
  if (error_code == emcy::kFollowingError) return "following error";
  switch (error_code >> 12) {
    case 0x1:
      return "generic error";
    case 0x2:
      return error_code == emcy::kOvercurrent ? "overcurrent" : "current";
    case 0x3:
      return "voltage";
    case 0x4:
      return "temperature";
    case 0x5:
      return "device hardware";
    case 0x6:
      return "device software";
    case 0x7:
      return "additional modules";
    case 0x8:
      return "monitoring (communication, control)";
    case 0x9:
      return "external error";
    case 0xF:
      return "additional functions";
    default:
      return "error";
  }
}

}  // namespace teleop::fieldbus::canopen
