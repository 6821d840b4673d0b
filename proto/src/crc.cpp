#include "teleop/proto/crc.hpp"

#include <boost/crc.hpp>

namespace teleop::proto {

std::uint32_t Crc32c(std::span<const std::uint8_t> bytes) noexcept {
  boost::crc_optimal<32, 0x1EDC6F41, 0xFFFFFFFF, 0xFFFFFFFF, true, true> crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

}  // namespace teleop::proto
