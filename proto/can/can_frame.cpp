#include "teleop/proto/can/can_frame.hpp"

namespace teleop::proto::can {

namespace {
constexpr std::array<std::size_t, 7> kFdLongLengths{12, 16, 20, 24, 32, 48, 64};
}  // namespace

bool IsValidFdLength(std::size_t len) noexcept {
  if (len <= kClassicMaxDataBytes) return true;
  for (const std::size_t l : kFdLongLengths) {
    if (l == len) return true;
  }
  return false;
}

std::size_t RoundUpToFdLength(std::size_t bytes) noexcept {
  if (bytes <= kClassicMaxDataBytes) return bytes;
  for (const std::size_t l : kFdLongLengths) {
    if (l >= bytes) return l;
  }
  return 0;
}

}  // namespace teleop::proto::can
