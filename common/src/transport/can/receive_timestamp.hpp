#pragma once

// Private to transport_can: the kernel's receive timestamp of a frame read with recvmsg (SocketCAN, and the UDP
// socket of a teleop-canbus node), on the loop's clock (CLOCK_MONOTONIC), as the UDP link takes it.

#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <ctime>

namespace teleop::transport::detail {

/// Room for one SCM_TIMESTAMPNS control message.
using ReceiveControl = std::array<std::uint8_t, CMSG_SPACE(sizeof(timespec))>;

/// Asks the kernel to stamp every datagram/frame received on `fd` (SO_TIMESTAMPNS). False when refused (the
/// receive times then fall back to the read time).
inline bool EnableReceiveTimestamps(int fd) noexcept {
  const int on = 1;
  return ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) == 0;
}

inline std::int64_t NowNs(clockid_t clock) noexcept {
  timespec now{};
  clock_gettime(clock, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

/// The SCM_TIMESTAMPNS stamp of a message recvmsg just returned, converted from CLOCK_REALTIME to CLOCK_MONOTONIC
/// (never later than now: a realtime step backwards could claim otherwise); the current monotonic time when the
/// message carries no stamp.
inline std::int64_t MonotonicReceiveTime(msghdr& message) noexcept {
  const std::int64_t monotonic = NowNs(CLOCK_MONOTONIC);
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec stamp{};
      std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
      const std::int64_t realtime_ns = static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000 + stamp.tv_nsec;
      return std::min(realtime_ns - (NowNs(CLOCK_REALTIME) - monotonic), monotonic);
    }
  }
  return monotonic;
}

/// One non-blocking recvmsg into `buffer` with room for the receive timestamp: the bytes read (-1 with errno when
/// nothing was read) and, when something was, its receive time on CLOCK_MONOTONIC in `receive_time_ns`.
inline ssize_t ReceiveStamped(int fd, void* buffer, std::size_t size, std::int64_t& receive_time_ns) noexcept {
  iovec iov{buffer, size};
  ReceiveControl control{};
  msghdr message{};
  message.msg_iov = &iov;
  message.msg_iovlen = 1;
  message.msg_control = control.data();
  message.msg_controllen = control.size();
  const ssize_t n = ::recvmsg(fd, &message, MSG_DONTWAIT);
  if (n >= 0) receive_time_ns = MonotonicReceiveTime(message);
  return n;
}

/// ppoll on one descriptor until it is readable (true) or CLOCK_MONOTONIC reaches `deadline_ns` (false).
inline bool WaitFdReadable(int fd, std::int64_t deadline_ns) noexcept {
  pollfd descriptor{fd, POLLIN, 0};
  const std::int64_t remaining = std::max<std::int64_t>(deadline_ns - NowNs(CLOCK_MONOTONIC), 0);
  const timespec timeout{static_cast<time_t>(remaining / 1'000'000'000), static_cast<long>(remaining % 1'000'000'000)};
  return ::ppoll(&descriptor, 1, &timeout, nullptr) > 0 && (descriptor.revents & POLLIN) != 0;
}

}  // namespace teleop::transport::detail
