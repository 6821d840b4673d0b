// libFuzzer harness: the version-1 UDP sample decoder (proto/src/codec.cpp). Properties: no crash or UB (ASan,
// UBSan); a datagram accepted decodes to a valid message that re-encodes to exactly the same bytes.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "fuzz_check.hpp"
#include "teleop/proto/codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace teleop::proto;
  const std::span<const std::uint8_t> bytes(data, size);
  SampleMessage message{};
  message.sequence = 0xDEADBEEF;
  const DecodeStatus status = DecodeSample(bytes, message);
  TELEOP_FUZZ_CHECK(status < DecodeStatus::kCount);
  TELEOP_FUZZ_CHECK(ToString(status) != nullptr);
  if (status != DecodeStatus::kOk) {
    TELEOP_FUZZ_CHECK(message.sequence == 0xDEADBEEF);  // untouched on rejection
    return 0;
  }
  TELEOP_FUZZ_CHECK(ValidateSample(message) == DecodeStatus::kOk);
  std::array<std::uint8_t, kMaxEncodedSampleBytes> out{};
  const std::size_t n = EncodeSample(message, out);
  TELEOP_FUZZ_CHECK(n == size);
  TELEOP_FUZZ_CHECK(std::memcmp(out.data(), data, size) == 0);
  return 0;
}
