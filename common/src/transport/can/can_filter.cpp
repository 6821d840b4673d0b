#include "teleop/transport/can_filter.hpp"

#include "teleop/proto/can/frame_layout.hpp"

namespace teleop::transport {

using proto::can::CanFrame;

namespace {

constexpr std::uint32_t kStandardMask = proto::can::kMaxStandardId;
constexpr std::uint32_t kExtendedMask = proto::can::kMaxExtendedId;

}  // namespace

CanFilter CanFilter::Exact(std::uint32_t id, bool extended) noexcept {
  return Masked(id, extended ? kExtendedMask : kStandardMask, extended);
}

CanFilter CanFilter::Masked(std::uint32_t id, std::uint32_t id_mask, bool extended) noexcept {
  const std::uint32_t width = extended ? kExtendedMask : kStandardMask;
  CanFilter f{};
  f.id = (id & width) | (extended ? kExtendedFlag : 0u);
  // The width and the remote flag are always compared: a data frame of this width only.
  f.mask = (id_mask & width) | kExtendedFlag | kRemoteFlag;
  return f;
}

CanFilter CanFilter::All() noexcept { return CanFilter{}; }

CanReceiveOptions CanReceiveOptions::Everything() {
  CanReceiveOptions options;
  options.filters = {CanFilter::All()};
  options.error_mask = proto::can::kErrTxTimeout | proto::can::kErrLostArbitration | proto::can::kErrController |
                       proto::can::kErrProtocol | proto::can::kErrTransceiver | proto::can::kErrNoAck |
                       proto::can::kErrBusOff | proto::can::kErrBusError | proto::can::kErrRestarted;
  options.fd = true;
  return options;
}

bool Matches(const CanFilter& filter, const CanFrame& frame) noexcept {
  if (frame.error) return false;
  const std::uint32_t word = (frame.id & (frame.extended ? kExtendedMask : kStandardMask)) |
                             (frame.extended ? CanFilter::kExtendedFlag : 0u) |
                             (frame.remote ? CanFilter::kRemoteFlag : 0u);
  const bool match = (word & filter.mask) == (filter.id & filter.mask);
  return match != filter.invert;
}

bool Accepts(const CanReceiveOptions& options, const CanFrame& frame) noexcept {
  if (frame.error) return (frame.error_class & options.error_mask) != 0;
  if (frame.fd && !options.fd) return false;
  for (const CanFilter& f : options.filters) {
    if (Matches(f, frame)) return true;
  }
  return false;
}

CanReceiveOptions LinkReceiveOptions(const proto::can::CanWireFormat& format, proto::SenderRole local_role) {
  CanReceiveOptions options;
  options.fd = format.fd;
  options.filters.clear();
  const std::uint32_t base = proto::can::BaseIdOf(format, proto::PeerOf(local_role));
  for (std::uint32_t k = 0; k < proto::can::kIdSpan; ++k) {
    options.filters.push_back(CanFilter::Exact(base + k, format.extended_id));
  }
  return options;
}

}  // namespace teleop::transport
