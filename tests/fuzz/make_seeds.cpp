// Writes the seed corpus of the fuzz harnesses (tests/fuzz/corpus/<harness>/) from the real encoders, so that the
// fuzzers start from valid messages: `deploy/fuzz.sh --seeds`. The output is committed; run it again after a wire
// change. Plain C++, no fuzzer runtime.
#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/proto/can/sample_codec.hpp"
#include "teleop/proto/codec.hpp"
#include "teleop/proto/secure_message.hpp"

namespace {

using namespace teleop::proto;
using Bytes = std::vector<std::uint8_t>;

void Write(const std::filesystem::path& dir, const std::string& name, const Bytes& bytes) {
  std::filesystem::create_directories(dir);
  std::ofstream out(dir / name, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

SampleMessage Sample(SenderRole sender, int dof, std::uint32_t sequence) {
  SampleMessage m;
  m.sender = sender;
  m.flags = kFlagEnabled | (sequence % 2 == 0 ? kFlagInFixture : kFlagShutdown);
  m.dof = static_cast<std::uint8_t>(dof);
  m.sequence = sequence;
  m.sender_time_ns = 1'000'000ull * sequence;
  m.echo_time_ns = m.sender_time_ns / 2;
  m.echo_age_ns = 250'000;
  for (int i = 0; i < dof; ++i) {
    m.position_m[i] = 0.01 * (i + 1) - 0.002 * sequence;
    m.velocity_m_per_s[i] = -0.1 * i;
    m.force_N[i] = 1.5 * i - 2.0;
  }
  return m;
}

Bytes EncodeV1(const SampleMessage& m) {
  Bytes out(MaxEncodedSampleSize());
  out.resize(EncodeSample(m, out));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
    return 2;
  }
  const std::filesystem::path root = argv[1];

  for (int dof = 1; dof <= kMaxWireDof; ++dof) {
    Write(root / "udp_sample", "dof" + std::to_string(dof), EncodeV1(Sample(SenderRole::kSlave, dof, 7u * dof)));
  }
  for (const int dof : {1, kMaxWireDof}) {  // with the energy block (time-domain passivity, energy_exchange)
    SampleMessage m = Sample(SenderRole::kMaster, dof, 11u * dof);
    m.has_energy = true;
    for (int i = 0; i < dof; ++i) {
      m.input_energy_J[i] = 0.5 * (i + 1);
      m.output_energy_J[i] = 0.25 * i;
    }
    Write(root / "udp_sample", "dof" + std::to_string(dof) + "_energy", EncodeV1(m));
  }

  const std::filesystem::path secure = root / "secure_messages";
  KeyExchangeMessage kx{};
  for (std::size_t i = 0; i < kx.ephemeral_key.size(); ++i) kx.ephemeral_key[i] = static_cast<std::uint8_t>(i);
  for (std::size_t i = 0; i < kx.tag.size(); ++i) kx.tag[i] = static_cast<std::uint8_t>(0xA0 + i);
  Bytes buf(kMaxSecureMessageSize);
  buf.resize(EncodeKeyExchange(kx, buf));
  Write(secure, "hello", buf);
  kx.type = SecureMessageType::kWelcome;
  kx.sender = SenderRole::kSlave;
  buf.assign(kMaxSecureMessageSize, 0);
  buf.resize(EncodeKeyExchange(kx, buf));
  Write(secure, "welcome", buf);
  ConfirmMessage confirm{};
  confirm.session_id = 0x0102030405060708;
  buf.assign(kMaxSecureMessageSize, 0);
  buf.resize(EncodeConfirm(confirm, buf));
  Write(secure, "confirm", buf);
  for (const int dof : {1, 6}) {
    SecureFrameHeader header{};
    header.sender = SenderRole::kMaster;
    header.session_id = 0x1122334455667788;
    header.sequence = 42;
    header.sealed_length = static_cast<std::uint16_t>(EncodedSampleSize(dof));
    buf.assign(kMaxSecureMessageSize, 0);
    const std::size_t n = EncodeSecureFrameHeader(header, buf);
    buf.resize(n + header.sealed_length + kFrameTagBytes);
    Write(secure, "frame_dof" + std::to_string(dof), buf);
  }
  Write(secure, "v1_sample", EncodeV1(Sample(SenderRole::kMaster, 1, 1)));

  // Session harness: mode byte + datagram (mode 0) or XOR mask (modes 1, 2; all-zero = the genuine message).
  const std::filesystem::path session = root / "secure_session";
  Write(session, "genuine_frame", Bytes(1 + 28 + 88 + 16, 0x00));
  Bytes mask(1 + 28 + 88 + 16, 0x00);
  mask[0] = 1;
  mask[1 + 28 + 7] = kFlagShutdown;  // flip the shutdown flag inside the ciphertext
  Write(session, "flipped_shutdown", mask);
  mask.assign(1 + 28, 0x00);
  mask[0] = 1;
  mask[1 + 23] = 0x80;  // huge sequence jump
  Write(session, "sequence_jump", mask);
  Bytes hello_mask(1 + 80, 0x00);
  hello_mask[0] = 2;
  Write(session, "genuine_hello", hello_mask);
  Bytes raw = {0x00};
  const Bytes v1 = EncodeV1(Sample(SenderRole::kMaster, 2, 3));
  raw.insert(raw.end(), v1.begin(), v1.end());
  Write(session, "v1_sample", raw);

  // Handshake harness: scripts of (op, argument) pairs (fuzz_handshake.cpp). Messages are captured in order: hello
  // 0, its welcome 1, the confirm 2, ...
  const std::filesystem::path handshake = root / "handshake";
  Write(handshake, "clean", Bytes{0, 1, 1, 0, 1, 1, 1, 2, 3, 0, 1, 3, 4, 0, 1, 4});
  Write(handshake, "duplicated_hello", Bytes{0, 1, 1, 0, 6, 0, 1, 1, 1, 2, 1, 3, 1, 4, 3, 0, 1, 5});
  Write(handshake, "replayed_old_hello", Bytes{0, 1, 1, 0, 1, 1, 1, 2, 0, 5, 1, 3, 1, 0, 1, 4, 1, 5, 1, 6});
  Write(handshake, "clock_back", Bytes{0, 50, 1, 0, 0, 0x90, 1, 1, 1, 0, 1, 2, 1, 3, 5, 10, 1, 1});
  Write(handshake, "mutated", Bytes{0, 1, 2, 0, 10, 1, 1, 0, 2, 1, 50, 2, 1, 1, 2, 2, 3, 4, 1, 2});

  // CAN harness: format byte, then per frame: control, id offset, length, data.
  const std::filesystem::path can_dir = root / "can_cycle";
  for (const int dof : {1, 3, 6, 12}) {
    for (const bool fd : {false, true}) {
      if (!fd && dof > can::kMaxClassicDof) continue;
      can::CanWireFormat format{};
      format.dof = dof;
      format.fd = fd;
      const std::uint8_t format_byte = static_cast<std::uint8_t>((dof - 1) | (fd ? 0x10 : 0) | 0x40);  // peer: slave
      Bytes stream = {format_byte};
      for (std::uint32_t cycle = 0; cycle < 3; ++cycle) {
        std::array<can::CanFrame, can::kMaxSlots> frames{};
        const can::EncodeResult r = can::EncodeCycle(Sample(SenderRole::kSlave, dof, cycle), format, frames);
        for (int f = 0; f < r.frames; ++f) {
          const can::CanFrame& frame = frames[f];
          stream.push_back(static_cast<std::uint8_t>((frame.extended ? 1 : 0) | (frame.fd ? 2 : 0) |
                                                     (frame.brs ? 4 : 0) | (f + 1 == r.frames ? 0x20 : 0)));
          stream.push_back(static_cast<std::uint8_t>(frame.id - can::BaseIdOf(format, SenderRole::kSlave)));
          stream.push_back(frame.len);
          stream.insert(stream.end(), frame.data.begin(), frame.data.begin() + frame.len);
        }
      }
      Write(can_dir, "dof" + std::to_string(dof) + (fd ? "_fd" : "_classic"), stream);
    }
  }

  // CANopen harness: 9 mapping bytes (a valid TPDO: 2 entries), then per frame: control, id (LE16), length, data.
  namespace co = teleop::fieldbus::canopen;
  const auto frame_bytes = [](Bytes& stream, const can::CanFrame& frame) {
    stream.push_back(static_cast<std::uint8_t>(frame.extended ? 1 : 0));
    stream.push_back(static_cast<std::uint8_t>(frame.id & 0xFF));
    stream.push_back(static_cast<std::uint8_t>(frame.id >> 8));
    stream.push_back(frame.len);
    stream.insert(stream.end(), frame.data.begin(), frame.data.begin() + frame.len);
  };
  const std::filesystem::path canopen_dir = root / "canopen_frames";
  const Bytes mapping = {0x84, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};  // TPDO 1, 2 entries of 16 bits
  const std::uint8_t node = 5;
  const std::vector<std::pair<std::string, std::vector<can::CanFrame>>> streams = {
      {"sdo",
       {co::EncodeSdoUploadRequest(node, 0x6041, 0), co::EncodeSdoUploadResponse(node, 0x6041, 0, 0x0237, 2),
        co::EncodeSdoDownloadRequest(node, 0x6060, 0, 10, 1), co::EncodeSdoDownloadResponse(node, 0x6060, 0),
        co::EncodeSdoAbort(co::cob::kSdoTx + node, 0x6071, 0, 0x06020000u)}},
      {"nmt_heartbeat_sync_emcy",
       {co::EncodeNmt(co::NmtCommand::kStart, node), co::EncodeHeartbeat(node, co::NmtState::kOperational),
        co::EncodeSync(), co::EncodeSync(co::cob::kSync, 7),
        co::EncodeEmergency(node, co::Emergency{0x2310, 0x03, {1, 2, 3, 4, 5}})}},
  };
  for (const auto& [name, frames] : streams) {
    Bytes stream = mapping;
    for (const can::CanFrame& frame : frames) frame_bytes(stream, frame);
    Write(canopen_dir, name, stream);
  }
  Bytes pdo_stream = mapping;
  co::PdoMapping pdo{};
  pdo.number = 1;
  pdo.entry_count = 2;
  pdo.entries[0] = {0x6041, 0, 16};
  pdo.entries[1] = {0x6077, 0, 16};
  can::CanFrame frame{};
  const std::array<std::uint32_t, 2> values = {0x0237, 0xFF38};
  if (co::PackPdo(pdo, co::cob::DefaultTpdo(1, node), values, frame)) frame_bytes(pdo_stream, frame);
  Write(canopen_dir, "pdo", pdo_stream);
  return 0;
}
