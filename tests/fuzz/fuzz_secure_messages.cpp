// libFuzzer harness: the version-2 framing decoders (proto/src/secure_codec.cpp): classify, hello/welcome,
// confirm, frame. Properties: no crash or UB; an accepted message re-encodes to the same bytes; a frame's views lie
// inside the datagram and cover it exactly.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "fuzz_check.hpp"
#include "teleop/proto/secure_message.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace teleop::proto;
  const std::span<const std::uint8_t> bytes(data, size);
  const DatagramKind kind = ClassifyDatagram(bytes);
  TELEOP_FUZZ_CHECK(kind.status == DecodeStatus::kOk || kind.status == DecodeStatus::kTooShort ||
                    kind.status == DecodeStatus::kBadMagic);
  std::array<std::uint8_t, 512> out{};

  KeyExchangeMessage kx{};
  if (DecodeKeyExchange(bytes, kx) == DecodeStatus::kOk) {
    TELEOP_FUZZ_CHECK(kind.status == DecodeStatus::kOk && kind.version == kSecureProtocolVersion);
    const std::size_t n = EncodeKeyExchange(kx, out);
    TELEOP_FUZZ_CHECK(n == size && std::memcmp(out.data(), data, size) == 0);
  }
  ConfirmMessage confirm{};
  if (DecodeConfirm(bytes, confirm) == DecodeStatus::kOk) {
    const std::size_t n = EncodeConfirm(confirm, out);
    TELEOP_FUZZ_CHECK(n == size && std::memcmp(out.data(), data, size) == 0);
  }
  SecureFrameView frame{};
  if (DecodeSecureFrame(bytes, frame) == DecodeStatus::kOk) {
    TELEOP_FUZZ_CHECK(frame.associated_data.data() == data);
    TELEOP_FUZZ_CHECK(frame.ciphertext.data() == data + frame.associated_data.size());
    TELEOP_FUZZ_CHECK(frame.tag.data() == frame.ciphertext.data() + frame.ciphertext.size());
    TELEOP_FUZZ_CHECK(frame.associated_data.size() + frame.ciphertext.size() + frame.tag.size() == size);
    TELEOP_FUZZ_CHECK(frame.ciphertext.size() == frame.header.sealed_length);
    TELEOP_FUZZ_CHECK(size <= kMaxSecureFrameSize);
    const std::size_t n = EncodeSecureFrameHeader(frame.header, out);
    TELEOP_FUZZ_CHECK(n == secure_wire::kFrameHeaderSize && std::memcmp(out.data(), data, n) == 0);
  }
  return 0;
}
