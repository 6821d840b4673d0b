#include "teleop/transport/can_socket_port.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <string>

#include "receive_timestamp.hpp"
#include "teleop/error.hpp"
#include "teleop/proto/can/frame_layout.hpp"

namespace teleop::transport {

using proto::can::CanFrame;

static_assert(proto::can::kErrTxTimeout == CAN_ERR_TX_TIMEOUT && proto::can::kErrLostArbitration == CAN_ERR_LOSTARB &&
              proto::can::kErrController == CAN_ERR_CRTL && proto::can::kErrProtocol == CAN_ERR_PROT &&
              proto::can::kErrTransceiver == CAN_ERR_TRX && proto::can::kErrNoAck == CAN_ERR_ACK &&
              proto::can::kErrBusOff == CAN_ERR_BUSOFF && proto::can::kErrBusError == CAN_ERR_BUSERROR &&
              proto::can::kErrRestarted == CAN_ERR_RESTARTED);
static_assert(proto::can::kCtrlRxOverflow == CAN_ERR_CRTL_RX_OVERFLOW &&
              proto::can::kCtrlTxOverflow == CAN_ERR_CRTL_TX_OVERFLOW &&
              proto::can::kCtrlRxWarning == CAN_ERR_CRTL_RX_WARNING &&
              proto::can::kCtrlTxWarning == CAN_ERR_CRTL_TX_WARNING &&
              proto::can::kCtrlRxPassive == CAN_ERR_CRTL_RX_PASSIVE &&
              proto::can::kCtrlTxPassive == CAN_ERR_CRTL_TX_PASSIVE && proto::can::kCtrlActive == CAN_ERR_CRTL_ACTIVE);

namespace {

constexpr const char* kNoAfCan =
    "AF_CAN not supported by this kernel: load can, can-raw, vcan (sudo modprobe can can-raw vcan; sudo ip link add "
    "dev vcan0 type vcan; sudo ip link set vcan0 up) or use the emulated bus, teleop-canbus (docs/can.md: "
    "link.transport emulated-can in a process's config, --bus-port PORT of teleop-drive and teleop-motor)";

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

bool AfCanAvailable() noexcept {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

SocketCanPort::SocketCanPort(const std::string& interface_name, const proto::can::CanWireFormat& format,
                             proto::SenderRole local_role)
    : SocketCanPort(interface_name, LinkReceiveOptions(format, local_role)) {}

SocketCanPort::SocketCanPort(const std::string& interface_name, const CanReceiveOptions& options)
    : fd_frames_(options.fd), filter_count_(options.filters.size()), interface_name_(interface_name) {
  if (options.filters.size() > kMaxCanFilters) {
    throw Error("SocketCAN: " + std::to_string(options.filters.size()) + " receive filters on " + interface_name +
                ", at most " + std::to_string(kMaxCanFilters));
  }
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) {
    if (errno == EAFNOSUPPORT || errno == EPROTONOSUPPORT || errno == ESOCKTNOSUPPORT) throw Error(kNoAfCan);
    throw Error(Errno("SocketCAN: socket(PF_CAN, SOCK_RAW, CAN_RAW) failed"));
  }
  try {
    if (interface_name.empty() || interface_name.size() >= IFNAMSIZ) {
      throw Error("SocketCAN: invalid interface name '" + interface_name + "'");
    }
    const unsigned index = ::if_nametoindex(interface_name.c_str());
    if (index == 0) {
      throw Error(
          "SocketCAN: no interface '" + interface_name +
          "' (ip link show; for a virtual bus: sudo ip link add dev vcan0 type vcan; sudo ip link set vcan0 up)");
    }
    if (options.fd) {
      ifreq ifr{};
      std::strncpy(ifr.ifr_name, interface_name.c_str(), IFNAMSIZ - 1);
      if (::ioctl(fd_, SIOCGIFMTU, &ifr) < 0) throw Error(Errno("SocketCAN: SIOCGIFMTU on " + interface_name));
      if (ifr.ifr_mtu != static_cast<int>(CANFD_MTU)) {
        throw Error("SocketCAN: '" + interface_name + "' is not CAN FD capable (MTU " + std::to_string(ifr.ifr_mtu) +
                    "; vcan: sudo ip link set " + interface_name + " mtu 72) — or set fd: false");
      }
      const int on = 1;
      if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof(on)) < 0) {
        throw Error(Errno("SocketCAN: CAN_RAW_FD_FRAMES"));
      }
    }
    // The filters go to the kernel as they are: CanFilter's words are struct can_filter's (flags in bits 31/30).
    static_assert(CanFilter::kExtendedFlag == CAN_EFF_FLAG && CanFilter::kRemoteFlag == CAN_RTR_FLAG);
    std::array<can_filter, kMaxCanFilters> filters{};
    for (std::size_t k = 0; k < options.filters.size(); ++k) {
      filters[k].can_id = options.filters[k].id | (options.filters[k].invert ? CAN_INV_FILTER : 0u);
      filters[k].can_mask = options.filters[k].mask;
    }
    // Zero filters: no data frames (the kernel takes a zero-length filter list as "receive nothing").
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, options.filters.empty() ? nullptr : filters.data(),
                     static_cast<socklen_t>(sizeof(can_filter) * options.filters.size())) < 0) {
      throw Error(Errno("SocketCAN: CAN_RAW_FILTER"));
    }
    const can_err_mask_t err_mask = options.error_mask & CAN_ERR_MASK;
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) < 0) {
      throw Error(Errno("SocketCAN: CAN_RAW_ERR_FILTER"));
    }
    // The receive time of the frame that completes a cycle is the data age's reference (docs/can.md); without
    // the stamp the read time stands in for it.
    (void)detail::EnableReceiveTimestamps(fd_);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(index);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) < 0) {  // NOLINT: sockets API
      throw Error(Errno("SocketCAN: bind to " + interface_name));
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
}

SocketCanPort::~SocketCanPort() {
  if (fd_ >= 0) ::close(fd_);
}

CanWriteStatus SocketCanPort::Write(const CanFrame& frame) noexcept {
  canfd_frame out{};
  out.can_id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0u) | (frame.remote ? CAN_RTR_FLAG : 0u);
  out.len = frame.len;
  out.flags = frame.fd && frame.brs ? CANFD_BRS : 0;
  std::memcpy(out.data, frame.data.data(), frame.len);
  const std::size_t size = frame.fd ? CANFD_MTU : CAN_MTU;
  if (frame.fd && !fd_frames_) return CanWriteStatus::kError;
  const ssize_t n = ::write(fd_, &out, size);
  if (n == static_cast<ssize_t>(size)) return CanWriteStatus::kOk;
  if (n < 0 && (errno == ENOBUFS || errno == EAGAIN)) return CanWriteStatus::kBufferFull;
  if (n < 0 && errno == ENETDOWN) return CanWriteStatus::kBusOff;  // interface down (bus-off without restart)
  return CanWriteStatus::kError;
}

bool SocketCanPort::Read(CanFrame& frame) noexcept {
  canfd_frame in{};
  std::int64_t received_ns = 0;
  const ssize_t n = detail::ReceiveStamped(fd_, &in, sizeof(in), received_ns);
  if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) return false;
  receive_time_ns_ = received_ns;
  frame = CanFrame{};
  frame.fd = n == static_cast<ssize_t>(CANFD_MTU);
  frame.brs = frame.fd && (in.flags & CANFD_BRS) != 0;
  frame.len = in.len > (frame.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN) ? 0 : in.len;
  std::memcpy(frame.data.data(), in.data, frame.len);
  if ((in.can_id & CAN_ERR_FLAG) != 0) {
    frame.error = true;
    frame.error_class = in.can_id & CAN_ERR_MASK;
    frame.len = CAN_ERR_DLC;
    std::memcpy(frame.data.data(), in.data, CAN_ERR_DLC);
    return true;
  }
  frame.extended = (in.can_id & CAN_EFF_FLAG) != 0;
  frame.remote = (in.can_id & CAN_RTR_FLAG) != 0;
  frame.id = in.can_id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  return true;
}

bool SocketCanPort::WaitReadable(std::int64_t deadline_ns) noexcept { return detail::WaitFdReadable(fd_, deadline_ns); }

std::string SocketCanPort::Describe() const {
  return "socketcan " + interface_name_ + (fd_frames_ ? " (FD frames)" : "") + ", " + std::to_string(filter_count_) +
         (filter_count_ == 1 ? " filter" : " filters");
}

}  // namespace teleop::transport
