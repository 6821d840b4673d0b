// Golden bytes and structural checks of the version-2 (authenticated session) framing, docs/protocol.md
// "Authenticated session". The cryptographic fields are opaque here; the session layer has its own tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/secure_message.hpp"

namespace teleop::proto {
namespace {

using Bytes = std::vector<std::uint8_t>;

template <std::size_t N>
std::array<std::uint8_t, N> Ramp(std::uint8_t first) {
  std::array<std::uint8_t, N> a{};
  for (std::size_t i = 0; i < N; ++i) a[i] = static_cast<std::uint8_t>(first + i);
  return a;
}

Bytes Append(Bytes head, std::span<const std::uint8_t> tail) {
  head.insert(head.end(), tail.begin(), tail.end());
  return head;
}

// The hello of docs/protocol.md: master, ephemeral key 00..1F, timestamp 0x1122334455667788, tag A0..BF.
const Bytes kGoldenHello = Append(Append(Append({0x54, 0x4C, 0x4F, 0x50, 0x02, 0x06, 0x00, 0x00}, Ramp<32>(0x00)),
                                         Bytes{0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11}),
                                  Ramp<32>(0xA0));
// The welcome: slave, ephemeral key 00..1F, tag A0..BF (no timestamp).
const Bytes kGoldenWelcome =
    Append(Append({0x54, 0x4C, 0x4F, 0x50, 0x02, 0x03, 0x01, 0x00}, Ramp<32>(0x00)), Ramp<32>(0xA0));
// The confirm: master, session id 0x0102030405060708, tag C0..DF.
const Bytes kGoldenConfirm = Append(
    {0x54, 0x4C, 0x4F, 0x50, 0x02, 0x04, 0x00, 0x00, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01}, Ramp<32>(0xC0));
// A frame header: slave, session id 0x1122334455667788, sequence 0x0000000100000002, 64 sealed bytes.
const Bytes kGoldenFrameHeader = {0x54, 0x4C, 0x4F, 0x50, 0x02, 0x05, 0x01, 0x00, 0x88, 0x77, 0x66, 0x55, 0x44, 0x33,
                                  0x22, 0x11, 0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x00};

TEST(SecureCodec, HelloAndWelcomeMatchTheGoldenBytes) {
  KeyExchangeMessage hello{};
  hello.type = SecureMessageType::kHello;
  hello.sender = SenderRole::kMaster;
  hello.ephemeral_key = Ramp<32>(0x00);
  hello.timestamp = 0x1122334455667788;
  hello.tag = Ramp<32>(0xA0);
  std::array<std::uint8_t, 100> out{};
  ASSERT_EQ(EncodeKeyExchange(hello, out), 80u);
  EXPECT_EQ(Bytes(out.begin(), out.begin() + 80), kGoldenHello);
  EXPECT_EQ(EncodeKeyExchange(hello, std::span(out).first(79)), 0u) << "short buffer";
  KeyExchangeMessage back{};
  ASSERT_EQ(DecodeKeyExchange(kGoldenHello, back), DecodeStatus::kOk);
  EXPECT_EQ(back.type, SecureMessageType::kHello);
  EXPECT_EQ(back.sender, SenderRole::kMaster);
  EXPECT_EQ(back.ephemeral_key, hello.ephemeral_key);
  EXPECT_EQ(back.timestamp, hello.timestamp);
  EXPECT_EQ(back.tag, hello.tag);

  // The welcome: type and sender, and no timestamp.
  KeyExchangeMessage welcome = hello;
  welcome.type = SecureMessageType::kWelcome;
  welcome.sender = SenderRole::kSlave;
  ASSERT_EQ(EncodeKeyExchange(welcome, out), 72u);
  EXPECT_EQ(Bytes(out.begin(), out.begin() + 72), kGoldenWelcome);
  EXPECT_EQ(EncodeKeyExchange(welcome, std::span(out).first(71)), 0u) << "short buffer";
  ASSERT_EQ(DecodeKeyExchange(kGoldenWelcome, back), DecodeStatus::kOk);
  EXPECT_EQ(back.type, SecureMessageType::kWelcome);
  EXPECT_EQ(back.timestamp, 0u);
  // The hello of the first release (type 2, 72 bytes, no timestamp) is refused by type, not mistaken for a short one.
  Bytes retired = kGoldenWelcome;
  retired[5] = kRetiredHelloType;
  retired[6] = 0x00;
  EXPECT_EQ(DecodeKeyExchange(retired, back), DecodeStatus::kBadType);
  // A welcome-sized hello and a hello-sized welcome are refused by size.
  Bytes short_hello = kGoldenWelcome;
  short_hello[5] = 0x06;
  short_hello[6] = 0x00;
  EXPECT_EQ(DecodeKeyExchange(short_hello, back), DecodeStatus::kTooShort);
  Bytes long_welcome = kGoldenHello;
  long_welcome[5] = 0x03;
  EXPECT_EQ(DecodeKeyExchange(long_welcome, back), DecodeStatus::kBadLength);
}

TEST(SecureCodec, ConfirmAndFrameHeaderMatchTheGoldenBytes) {
  ConfirmMessage confirm{};
  confirm.sender = SenderRole::kMaster;
  confirm.session_id = 0x0102030405060708;
  confirm.tag = Ramp<32>(0xC0);
  std::array<std::uint8_t, 64> out{};
  ASSERT_EQ(EncodeConfirm(confirm, out), 48u);
  EXPECT_EQ(Bytes(out.begin(), out.begin() + 48), kGoldenConfirm);
  ConfirmMessage back{};
  ASSERT_EQ(DecodeConfirm(kGoldenConfirm, back), DecodeStatus::kOk);
  EXPECT_EQ(back.session_id, confirm.session_id);
  EXPECT_EQ(back.tag, confirm.tag);

  SecureFrameHeader header{};
  header.sender = SenderRole::kSlave;
  header.session_id = 0x1122334455667788;
  header.sequence = 0x0000000100000002;
  header.sealed_length = 64;
  ASSERT_EQ(EncodeSecureFrameHeader(header, out), 28u);
  EXPECT_EQ(Bytes(out.begin(), out.begin() + 28), kGoldenFrameHeader);
  header.sealed_length = 65;  // not a sample size
  EXPECT_EQ(EncodeSecureFrameHeader(header, out), 0u);

  const auto nonce = FrameNonce(SenderRole::kSlave, 0x0102030405060708);
  EXPECT_EQ(Bytes(nonce.begin(), nonce.end()),
            (Bytes{0x01, 0x00, 0x00, 0x00, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01}));
}

TEST(SecureCodec, FrameDecodeGivesViewsIntoTheDatagram) {
  Bytes frame = kGoldenFrameHeader;
  for (int i = 0; i < 64 + 16; ++i) frame.push_back(static_cast<std::uint8_t>(i));
  SecureFrameView view{};
  ASSERT_EQ(DecodeSecureFrame(frame, view), DecodeStatus::kOk);
  EXPECT_EQ(view.header.sender, SenderRole::kSlave);
  EXPECT_EQ(view.header.session_id, 0x1122334455667788u);
  EXPECT_EQ(view.header.sequence, 0x0000000100000002u);
  EXPECT_EQ(view.associated_data.data(), frame.data());
  EXPECT_EQ(view.associated_data.size(), 28u);
  EXPECT_EQ(view.ciphertext.data(), frame.data() + 28);
  EXPECT_EQ(view.ciphertext.size(), 64u);
  EXPECT_EQ(view.tag.data(), frame.data() + 92);
  EXPECT_EQ(view.tag.size(), 16u);
  // Every sample size 64 + 24k, or 80 + 40k with the energy block (k = 0..11: 1..12 DOF), is a valid sealed
  // length; others are not.
  for (std::uint16_t n = 0; n < 560; ++n) {
    std::array<std::uint8_t, 28 + 560 + 16> buffer{};
    std::copy(kGoldenFrameHeader.begin(), kGoldenFrameHeader.end(), buffer.begin());
    buffer[24] = static_cast<std::uint8_t>(n);
    buffer[25] = static_cast<std::uint8_t>(n >> 8);
    const bool sample_size = (n >= 64 && n <= 328 && (n - 64) % 24 == 0) || (n >= 80 && n <= 520 && (n - 80) % 40 == 0);
    EXPECT_EQ(DecodeSecureFrame(std::span(buffer).first(28 + n + 16), view),
              sample_size ? DecodeStatus::kOk : DecodeStatus::kBadLength)
        << n;
  }
}

TEST(SecureCodec, DecodersRejectInTheDocumentedOrder) {
  KeyExchangeMessage kx{};
  ConfirmMessage confirm{};
  SecureFrameView frame{};
  const auto with = [](Bytes b, std::size_t at, std::uint8_t value) {
    b[at] = value;
    return b;
  };
  EXPECT_EQ(DecodeKeyExchange(Bytes(kGoldenHello.begin(), kGoldenHello.begin() + 7), kx), DecodeStatus::kTooShort);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 0, 0x55), kx), DecodeStatus::kBadMagic);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 4, 0x01), kx), DecodeStatus::kBadVersion);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 5, 0x04), kx), DecodeStatus::kBadType);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 5, 0x02), kx), DecodeStatus::kBadType);
  EXPECT_EQ(DecodeKeyExchange(Bytes(kGoldenHello.begin(), kGoldenHello.end() - 1), kx), DecodeStatus::kTooShort);
  EXPECT_EQ(DecodeKeyExchange(Append(kGoldenHello, std::array<std::uint8_t, 1>{}), kx), DecodeStatus::kBadLength);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 6, 0x02), kx), DecodeStatus::kOutOfRange);
  EXPECT_EQ(DecodeKeyExchange(with(kGoldenHello, 7, 0x01), kx), DecodeStatus::kOutOfRange);

  EXPECT_EQ(DecodeConfirm(with(kGoldenConfirm, 5, 0x02), confirm), DecodeStatus::kBadType);
  EXPECT_EQ(DecodeConfirm(Bytes(kGoldenConfirm.begin(), kGoldenConfirm.end() - 1), confirm), DecodeStatus::kTooShort);
  EXPECT_EQ(DecodeConfirm(with(kGoldenConfirm, 7, 0x80), confirm), DecodeStatus::kOutOfRange);

  Bytes f = kGoldenFrameHeader;
  f.resize(28 + 64 + 16);
  EXPECT_EQ(DecodeSecureFrame(Bytes(f.begin(), f.begin() + 27), frame), DecodeStatus::kTooShort);
  EXPECT_EQ(DecodeSecureFrame(Bytes(f.begin(), f.end() - 1), frame), DecodeStatus::kTooShort);
  EXPECT_EQ(DecodeSecureFrame(Append(f, std::array<std::uint8_t, 1>{}), frame), DecodeStatus::kBadLength);
  EXPECT_EQ(DecodeSecureFrame(with(f, 26, 0x01), frame), DecodeStatus::kOutOfRange);
  EXPECT_EQ(DecodeSecureFrame(with(f, 6, 0x07), frame), DecodeStatus::kOutOfRange);

  // A version-2 datagram is not a version-1 sample and vice versa: both decoders say so by version.
  SampleMessage sample{};
  EXPECT_EQ(DecodeSample(f, sample), DecodeStatus::kBadVersion);
  std::array<std::uint8_t, 64> v1{};
  sample.dof = 1;
  ASSERT_EQ(EncodeSample(sample, v1), 64u);
  EXPECT_EQ(DecodeSecureFrame(v1, frame), DecodeStatus::kBadVersion);
  const DatagramKind kind = ClassifyDatagram(v1);
  EXPECT_EQ(kind.status, DecodeStatus::kOk);
  EXPECT_EQ(kind.version, kProtocolVersion);
  EXPECT_EQ(kind.type, 1u);
  EXPECT_EQ(ClassifyDatagram(Bytes{0x54, 0x4C, 0x4F, 0x50, 0x02}).status, DecodeStatus::kTooShort);
}

// The hex dumps in docs/protocol.md ("Authenticated session") are these golden bytes: the leading run of two-digit
// hex tokens of each line of the fenced block after `marker`.
Bytes DocDump(const std::string& marker) {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/docs/protocol.md");
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const std::size_t at = doc.find(marker);
  if (at == std::string::npos) return {};
  const std::size_t begin = doc.find("```\n", at);
  const std::size_t end = doc.find("```", begin + 4);
  if (begin == std::string::npos || end == std::string::npos) return {};
  Bytes out;
  std::istringstream lines(doc.substr(begin + 4, end - begin - 4));
  for (std::string line; std::getline(lines, line);) {
    std::istringstream tokens(line);
    for (std::string t; tokens >> t;) {
      if (t.size() != 2 || !std::isxdigit(static_cast<unsigned char>(t[0])) ||
          !std::isxdigit(static_cast<unsigned char>(t[1]))) {
        break;
      }
      out.push_back(static_cast<std::uint8_t>(std::stoul(t, nullptr, 16)));
    }
  }
  return out;
}

TEST(SecureCodec, TheProtocolPageShowsTheGoldenBytes) {
  EXPECT_EQ(DocDump("Example hello"), kGoldenHello);
  EXPECT_EQ(DocDump("Example frame header"), kGoldenFrameHeader);
}

}  // namespace
}  // namespace teleop::proto
